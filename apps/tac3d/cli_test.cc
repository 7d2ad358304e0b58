// The command line as a user runs it: bad arguments get a clear error and exit code 1
// before any work, and nothing is left half-written (issue 14, defects 6, 7 and 8).
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

Outcome RunCli(const std::string& arguments) {
  const std::string command = std::string(TAC3D_CLI_PATH) + " " + arguments + " 2>&1";
  Outcome outcome;
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return outcome;
  char buffer[4096];
  while (const size_t n = std::fread(buffer, 1, sizeof(buffer), pipe))
    outcome.output.append(buffer, n);
  const int status = ::pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

int CountFiles(const std::string& dir) {
  return static_cast<int>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

TEST(Cli, DesignChecksEveryOutputBeforeWritingAny) {
  const std::string dir = testing::MakeTempDir("design");
  Outcome o = RunCli(fmt::format("design --out {0}/s.yaml --png {0}/x.notanext", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--png '" + dir + "/x.notanext' must end in .png"));
  o = RunCli(fmt::format("design --out {0}/s.yaml --svg {0}/missing/d.svg", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("the folder '" + dir + "/missing' does not exist"));
  EXPECT_EQ(CountFiles(dir), 0) << "a failed design left a file behind";
  o = RunCli(fmt::format("design --out {0}/s.yaml --png {0}/d.png --svg {0}/d.svg", dir));
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_EQ(CountFiles(dir), 3);
}

TEST(Cli, CalibrateForceSaysWhatItNeedsBeforeAnyWork) {
  Outcome o = RunCli("calibrate-force");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("calibrate-force needs --pairs or --presses"));
  // Checked before the compliance family is built (minutes on the default sensor).
  o = RunCli("calibrate-force --presses missing.csv --cache " + testing::MakeTempDir("cf"));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("needs --noise-mm (for the discrepancy principle) or --weight"));
  o = RunCli("calibrate-force --presses a.csv --pairs b.csv");
  EXPECT_NE(o.exit_code, 0);  // CLI11's own code for a usage error
  EXPECT_THAT(o.output, HasSubstr("excludes"));
}

TEST(Cli, RecordingPairsChecksItsOutputsBeforeReading) {
  const std::string dir = testing::MakeTempDir("pairs");
  Outcome o = RunCli(fmt::format("recording pairs {0}/none.t3r --reference {0}/none.csv", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("needs --pairs-out or --presses-out"));
  o = RunCli(fmt::format(
      "recording pairs {0}/none.t3r --reference {0}/none.csv --pairs-out {0}/missing/p.csv", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("the folder '" + dir + "/missing' does not exist"));
  o = RunCli(fmt::format(
      "recording pairs {0}/none.t3r --reference {0}/none.csv --pairs-out {0}/p.csv", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("none.csv"));
  EXPECT_EQ(CountFiles(dir), 0);
}

TEST(Cli, DesignRefusesAThicknessBeyondTheLimit) {
  const Outcome o = RunCli("design --d 1e9 --out " + testing::MakeTempDir("d") + "/s.yaml");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("d_mm = 1000000000 must be > 0 and <= 1000 mm"));
}

TEST(Cli, TwinRunsRefuseTooFewStepsAndABadRefinementBeforeAnyWork) {
  const std::string dir = testing::MakeTempDir("twin_runs");
  Outcome o = RunCli(fmt::format("demo --out {}/demo --steps 60", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--steps 60: the demo needs 0 (every step) or at least 70"));
  o = RunCli(fmt::format("demo --out {}/demo --steps 70 --twin-refinement 0.5", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--twin-refinement must be in [1, 4], got 0.5"));
  o = RunCli(fmt::format("simulate --scene force_calibration --out {}/sim --twin-refinement nan", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--twin-refinement must be in [1, 4], got nan"));
  EXPECT_EQ(CountFiles(dir), 0) << "a refused run left a file behind";
}

TEST(Cli, RenderRefusesANegativeFrameAndANonFinitePose) {
  const std::string dir = testing::MakeTempDir("render");
  Outcome o = RunCli(fmt::format("render markers --frame -1 --out {}/f.png", dir));
  EXPECT_NE(o.exit_code, 0);
  EXPECT_THAT(o.output, HasSubstr("--frame"));
  o = RunCli(fmt::format("render board --pose nan,0,0,0,0,0 --out {}/b.png", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("every number must be finite"));
  EXPECT_EQ(CountFiles(dir), 0);
}

TEST(Cli, CalibrateChecksItsOutputBeforeCalibrating) {
  const std::string dir = testing::MakeTempDir("calibrate");
  const Outcome o =
      RunCli(fmt::format("calibrate --images {0} --out {0}/missing/sensor.yaml", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("the folder '" + dir + "/missing' does not exist"));
}

TEST(Cli, RunRefusesContradictoryFlagsAndNamesWhatASourceIs) {
  const std::string dir = testing::MakeTempDir("run");
  Outcome o = RunCli(fmt::format("run --source {} --record-images", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--record-images needs --record FILE"));
  o = RunCli(fmt::format("run --source /dev/null --config {}", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("sensor config '" + dir + "' is a directory, not a file"));
  o = RunCli("run --source /dev/null");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("'/dev/null' is neither a file nor a folder"));
  std::ofstream(dir + "/notes.txt") << "not a video\n";
  o = RunCli(fmt::format("run --source {}/notes.txt", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_EQ(std::count(o.output.begin(), o.output.end(), '\n'), 1) << "more than the error:\n"
                                                                   << o.output;
}

TEST(Cli, RunRefusesAnUnknownUdpItemListingTheKnownOnes) {
  const std::string dir = testing::MakeTempDir("run_udp");
  Outcome o = RunCli(fmt::format("run --source {} --udp 127.0.0.1:9988 --udp-items Normals", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--udp-items 'Normals': unknown item 'Normals'; the items to add "
                                  "to the vendor's six are 3D_Normals, SlipState, SlipFraction, "
                                  "Friction, FrictionSigma (or all)"));
  o = RunCli(fmt::format("run --source {} --udp-items all", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--udp-items needs --udp HOST:PORT"));
  o = RunCli(fmt::format("run --source {} --udp-progress", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--udp-progress needs --udp HOST:PORT"));
}

TEST(Cli, RunFileMistakesAreRefusedBeforeAnyWork) {
  const std::string dir = testing::MakeTempDir("run_file");
  std::ofstream(dir + "/hand.yaml") << "sensors:\n  - sn: A\n    source: camera:0\n    colour: red\n";
  Outcome o = RunCli(fmt::format("run --run-file {}/hand.yaml", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr(dir + "/hand.yaml: line 4: sensors[0].colour: unknown key"));
  o = RunCli(fmt::format("run --run-file {}/hand.yaml --sn B", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--sn is given per sensor in the run file"));
  o = RunCli(fmt::format("run --run-file {}/hand.yaml --udp-items all", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--udp-items is given per sensor in the run file"));
  o = RunCli("run");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--source or --run-file is required"));
  std::ofstream(dir + "/hand.yaml") << "sensors:\n  - sn: A\n    source: camera:0\n    udp: nowhere\n";
  o = RunCli(fmt::format("run --run-file {}/hand.yaml", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr(dir + "/hand.yaml: line 4: sensors[0].udp: --udp 'nowhere': expected HOST:PORT"));
}

TEST(Cli, ViewNeedsSomethingToShow) {
  Outcome o = RunCli("view");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("give --recording FILE or --dataset DIR, and/or --friction-map"));
  o = RunCli("view --recording a.rec --dataset b");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--recording and --dataset exclude each other"));
  o = RunCli("view --recording a.rec --config s.yaml");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--config applies to --dataset only"));
}

}  // namespace
}  // namespace tac3d
