// The command line as a user runs it: bad arguments get a clear error and exit code 1
// before any work, and nothing is left half-written.
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

Outcome RunCli(const std::string& arguments, const std::string& prefix = "") {
  const std::string command = prefix + std::string(TAC3D_CLI_PATH) + " " + arguments + " 2>&1";
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

// As RunCli, killed after `seconds` and with its address space capped at 2 GB, so a reproducer
// that used to hang or fill memory fails its test (exit code 137) instead of the machine.
Outcome RunCliBounded(const std::string& arguments, int seconds = 20) {
  return RunCli(arguments, fmt::format("ulimit -v 2000000; timeout -s KILL {} ", seconds));
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
  EXPECT_THAT(o.output, HasSubstr("calibrate-force needs --pairs, --presses or --vendor-recording"));
  // Checked before the compliance family is built (minutes on the default sensor).
  o = RunCli("calibrate-force --presses missing.csv --cache " + testing::MakeTempDir("cf"));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("needs --noise-mm (for the discrepancy principle) or --weight"));
  o = RunCli("calibrate-force --presses a.csv --pairs b.csv");
  EXPECT_NE(o.exit_code, 0);  // CLI11's own code for a usage error
  EXPECT_THAT(o.output, HasSubstr("excludes"));
  o = RunCli("calibrate-force --vendor-recording rec");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--vendor-recording needs the sensor's --config"));
  // A config without a vendor camera model: the built-in prototype has no factory calibration.
  const std::string dir = testing::MakeTempDir("cf_vendor");
  SaveSensorConfig(DefaultSensorConfig(), dir + "/proto.yaml");
  o = RunCli(fmt::format("calibrate-force --vendor-recording rec --config {}/proto.yaml", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("has no vendor camera model"));
}

// Issue 27: gains fitted to noise (R^2 -0.08 and -1.00) were printed as usable.
TEST(Cli, CalibrateForceRefusesGainsFittedToNoise) {
  const std::string dir = testing::MakeTempDir("gains");
  // Normal presses: fz measured and referenced alike, fx and fy noise on both sides (their
  // products sum positive, so only R^2 can refuse them).
  std::ofstream(dir + "/pairs.csv") << "fx_meas,fy_meas,fz_meas,fx_ref,fy_ref,fz_ref\n"
                                       "0.02,0.01,-2.0,0.03,-0.03,-2.2\n"
                                       "-0.01,0.03,-4.1,0.02,0.01,-4.5\n"
                                       "0.03,-0.02,-6.0,0.01,-0.02,-6.6\n"
                                       "-0.02,-0.01,-8.2,-0.03,0.02,-9.0\n";
  Outcome o = RunCli(fmt::format("calibrate-force --pairs {}/pairs.csv", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, ::testing::ContainsRegex("the fx gain's R\\^2 is 0.344, the fy gain's R\\^2 "
                                                 "is -0.043 \\(over 4 pairs\\), under the floor 0.9"));
  EXPECT_THAT(o.output, HasSubstr("add presses with shear"));
  EXPECT_THAT(o.output, Not(HasSubstr("use them with")));
  // Asked to take any fit, it prints the gains and their R^2.
  o = RunCli(fmt::format("calibrate-force --pairs {}/pairs.csv --min-r-squared -100", dir));
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("use them with"));
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

// Issue 27: the answer came after ~100 lines of rejected roots; they are --verbose's now.
TEST(Cli, DesignPrintsTheRejectedRootsOnlyWhenVerbose) {
  const std::string dir = testing::MakeTempDir("design_verbose");
  Outcome o = RunCli(fmt::format("design --out {}/s.yaml", dir));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("parallax angle"));
  EXPECT_THAT(o.output, Not(HasSubstr("impossible")));
  EXPECT_THAT(o.output, Not(HasSubstr("      - ")));
  o = RunCli(fmt::format("design --out {}/s.yaml --verbose", dir));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr(": impossible (max residual"));
  EXPECT_THAT(o.output, HasSubstr("      - "));
  EXPECT_THAT(o.output, HasSubstr("parallax angle"));
  // With no valid root the error says where the reasons are.
  o = RunCli(fmt::format("design --h 20 --out {}/s.yaml", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("(--verbose prints each root's reasons)"));
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

TEST(Cli, EvalIncipientRefusesBadOptionsBeforeAnyWork) {
  const std::string dir = testing::MakeTempDir("eval_incipient");
  // Exit code 1 for tac3d::Error, 105 for CLI11's validation errors (a name not in a list).
  const auto refused = [&](const std::string& options, const std::string& message, int exit_code = 1) {
    const Outcome o = RunCli(fmt::format("eval incipient --out {}/out {}", dir, options));
    EXPECT_EQ(o.exit_code, exit_code) << options;
    EXPECT_THAT(o.output, HasSubstr(message)) << options;
  };
  refused("--mu 0.3 2.5", "--mu must be in (0, 2], got 2.5");
  refused("--frame-rate 2", "--frame-rate must be in [5, 1000], got 2");
  refused("--steps 10", "--steps: the evaluation needs every step of a scene");
  refused("--twin-refinement 0.5", "--twin-refinement must be in [1, 4], got 0.5");
  refused("--indenters cone", "--indenters: cone not in {sphere,cylinder,punch}", 105);
  refused("--ramps medium", "medium", 105);
  EXPECT_EQ(CountFiles(dir), 0) << "a refused run left a file behind";
}

TEST(Cli, DriftModesAreNamedInHelpAndErrors) {
  for (const char* command : {"run --help", "eval conditions --help"}) {
    const Outcome o = RunCli(command);
    EXPECT_EQ(o.exit_code, 0);
    EXPECT_THAT(o.output, HasSubstr("--drift ENUM:{off, flag, rezero}")) << command;
    EXPECT_THAT(o.output, ::testing::Not(HasSubstr("->"))) << command;
  }
  const Outcome o = RunCli("run --source camera:0 --drift sometimes");
  EXPECT_EQ(o.exit_code, 105);  // CLI11's exit code for a validation error
  EXPECT_THAT(o.output, HasSubstr("--drift: 'sometimes' is not off, flag or rezero"));
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
                                  "Friction, FrictionSigma, SlipMargin (or all)"));
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
  EXPECT_THAT(o.output, HasSubstr("give --recording FILE, --vendor DIR or --dataset DIR, and/or --friction-map"));
  o = RunCli("view --recording a.rec --dataset b");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--recording, --vendor and --dataset exclude each other"));
  o = RunCli("view --vendor a --recording b.rec");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--recording, --vendor and --dataset exclude each other"));
  o = RunCli("view --vendor a --sn X");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--sn applies to --dataset only"));
  o = RunCli("view --recording a.rec --config s.yaml");
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--config applies to --dataset only"));
}


// ---- Issue 22: each reproducer ends in a clear error within seconds, in bounded memory --------

// Eight levels of ten aliases of the level above (332 bytes): 10^8 values for every reader.
std::string AliasBomb() {
  std::string text = "a: &a [x, x, x, x, x, x, x, x, x, x]\n";
  for (char level = 'b'; level <= 'h'; ++level) {
    text += fmt::format("{0}: &{0} [", level);
    for (int k = 0; k < 10; ++k) text += fmt::format("{}*{}", k ? ", " : "", char(level - 1));
    text += "]\n";
  }
  return text;
}

// Defect 7: `design --config` ran 60 s+ of CPU, the run file too; an alias inside its own node
// crashed (SIGSEGV).
TEST(Cli, YamlAliasesAreBoundedInEveryFile) {
  const std::string dir = testing::MakeTempDir("aliases");
  std::ofstream(dir + "/bomb.yaml") << AliasBomb();
  const std::string expected =
      dir + "/bomb.yaml: line 4: the aliases (*name) stand for more than 10000 values in all";
  Outcome o = RunCliBounded(fmt::format("design --config {0}/bomb.yaml --out {0}/s.yaml", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr(expected));
  o = RunCliBounded(fmt::format("run --run-file {}/bomb.yaml", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr(expected));
  std::ofstream(dir + "/self.yaml") << "name: x\nobjects: &o [*o]\n";
  o = RunCliBounded(fmt::format("simulate --scene {0}/self.yaml --out {0}/ds", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr(dir + "/self.yaml: line 2: an alias (*name) inside the node it names"));
}

// Defect 8: /dev/zero grew to 2.2 GB before "is empty"; a folder was "empty".
TEST(Cli, PoseAndPositionReadersRefuseDevicesAndFolders) {
  const std::string dir = testing::MakeTempDir("readers");
  Outcome o = RunCliBounded(
      fmt::format("friction-map --recording {0}/r.t3r --poses /dev/zero --out {0}/map", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("pose CSV '/dev/zero' is not a regular file"));
  o = RunCliBounded(fmt::format("friction-map --recording {0}/r.t3r --poses {0} --out {0}/map", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("pose CSV '" + dir + "' is a directory, not a file"));
  o = RunCliBounded(fmt::format("render markers --positions /dev/zero --out {}/m.png", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("marker positions '/dev/zero' is not a regular file"));
  o = RunCliBounded(fmt::format("render markers --positions {0} --out {0}/m.png", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("marker positions '" + dir + "' is a directory, not a file"));
  EXPECT_EQ(CountFiles(dir), 0);
}

// Defect 9: calibrate-force started the FEM solves before reading its presses (with /dev/zero:
// 56 s, 1.6 GB, then the refusal); render-set kept 100000 images in memory.
TEST(Cli, CalibrationCommandsCheckTheirInputsBeforeAnyWork) {
  const std::string cache = testing::MakeTempDir("cf_cache");
  for (const char* presses : {"/nonexistent.csv", "/dev/zero"}) {
    const Outcome o = RunCliBounded(fmt::format(
        "calibrate-force --presses {} --noise-mm 0.002 --cache {}", presses, cache));
    EXPECT_EQ(o.exit_code, 1) << o.output;
    EXPECT_THAT(o.output, HasSubstr(fmt::format("calibration presses '{}'", presses)));
    EXPECT_THAT(o.output, Not(HasSubstr("fem:"))) << "the FEM started first";
  }
  EXPECT_EQ(CountFiles(cache), 0);
  const std::string out = testing::MakeTempDir("render_set") + "/set";
  const Outcome o = RunCliBounded(fmt::format("calibrate render-set --count 100000 --out {}", out));
  EXPECT_NE(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--count: Value 100000 not in range 1 to 1000"));
  EXPECT_FALSE(fs::exists(out));
}

// Defect 11: messages that said too little, too much, or named the wrong thing.
TEST(Cli, MessagesNameTheFlagAndTheBoundShortly) {
  const std::string dir = testing::MakeTempDir("messages");
  Outcome o = RunCliBounded(fmt::format("render markers --frame -1 --out {}/f.png", dir));
  EXPECT_NE(o.exit_code, 0);
  EXPECT_THAT(o.output, HasSubstr("--frame: '-1' must be a whole number >= 0"));
  EXPECT_LT(o.output.size(), 200u) << o.output;
  o = RunCliBounded(fmt::format("render markers --read-noise 1e300 --out {}/f.png", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("read_noise_dn = 1e+300 must be in [0, 255] DN"));
  // Issue 24: a JPEG quality outside libjpeg's range, with the real-image nuisances too.
  o = RunCliBounded(
      fmt::format("render markers --real-image-nuisances --jpeg-quality 101 --out {}/f.png", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("render options: jpeg_quality = 101 must be in [0, 100] (0: none)"));
  EXPECT_FALSE(fs::exists(dir + "/f.png"));
  o = RunCliBounded(fmt::format("run --source {0}/r.t3r --web 127.0.0.1:0 --web-hold nan", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--web-hold nan must be a number of seconds"));
  std::ofstream(dir + "/pairs.csv") << "fx_meas,fy_meas,fz_meas,fx_ref,fy_ref,fz_ref\n"
                                    << "1e300,1e300,1e300,1e300,1e300,1e300\n";
  o = RunCliBounded(fmt::format("calibrate-force --pairs {}/pairs.csv", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("pairs.csv:2: field 1 '1e300' is beyond +-10000"));
  EXPECT_THAT(o.output, Not(HasSubstr("nan")));
  std::ofstream(dir + "/long.csv") << std::string(26000, 'x') << "\n";
  o = RunCliBounded(fmt::format("calibrate-force --pairs {}/long.csv", dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_LT(o.output.size(), 400u) << "the first line echoed whole";
  o = RunCliBounded(fmt::format(
      "recording pairs {0}/r.t3r --reference {0}/ref.csv --pairs-out {0}/p.csv --max-offset 1e9",
      dir));
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_THAT(o.output, HasSubstr("--max-offset = 1000000000 must be in [0, 600] s"));
  EXPECT_THAT(o.output, Not(HasSubstr("ReferenceJoinOptions")));
}

// Defect 11: `--gains 1e300` and `--fps 1e300` were accepted (and the twin model's build
// started); both are refused before the model is loaded.
TEST(Cli, RunRefusesGainsAndFrameRatesNoSensorHasBeforeTheModel) {
  const std::string dir = testing::MakeTempDir("run_bounds");
  const std::string cache = testing::MakeTempDir("run_bounds_cache");
  ASSERT_EQ(RunCli(fmt::format("render markers --no-noise --out {}/a.png", dir)).exit_code, 0);
  Outcome o = RunCliBounded(
      fmt::format("run --source {} --gains 1e300 1 1 --max-frames 1 --cache {}", dir, cache));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("gains.x must be in (0, 1000], got 1e+300"));
  o = RunCliBounded(fmt::format("run --source {} --fps 1e300 --max-frames 1 --cache {}", dir, cache));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("image folder: fps = 1e+300 must be in (0, 1000]"));
  EXPECT_EQ(CountFiles(cache), 0) << "the model was built before the check";
}

// Defect 11: calibrate said "unreadable or corrupt file" where run says why.
TEST(Cli, CalibrateSaysWhyAnImageIsRefused) {
  const std::string dir = testing::MakeTempDir("calibrate_header");
  ASSERT_EQ(RunCli(fmt::format("render markers --no-noise --out {}/reference.png", dir)).exit_code, 0);
  std::fstream png(dir + "/reference.png", std::ios::in | std::ios::out | std::ios::binary);
  const char side[4] = {0x00, 0x00, char(0xEA), 0x60};  // 60000, big-endian: IHDR width, height
  png.seekp(16).write(side, 4).write(side, 4);
  png.close();
  std::ofstream(dir + "/board.yaml")
      << "board: {layout: symmetric, rows: 7, cols: 7, spacing_mm: 2.5, dot_diameter_mm: 1.2}\n"
         "reference:\n  image: reference.png\n  sensor_from_board:\n"
         "    position_mm: [-7.5, -7.5, 0]\n    rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n";
  const Outcome o = RunCliBounded(fmt::format("calibrate --images {0} --out {0}/cal.yaml", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("its header claims 60000 x 60000 pixels"));
}

// `tac3d track` on what holds no frame: refused, saying what and where, nothing written.
TEST(Cli, TrackRefusesAMalformedVideoAndAnEmptyFolder) {
  const std::string dir = testing::MakeTempDir("track_refusals");
  fs::create_directories(dir + "/empty");
  Outcome o = RunCliBounded(fmt::format("track --source {0}/empty --out {0}/t.csv", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr(fmt::format("image folder '{}/empty' holds no image file", dir)));
  std::ofstream(dir + "/broken.avi") << "RIFF....AVI LIST: text, not a video";
  o = RunCliBounded(fmt::format("track --source {0}/broken.avi --out {0}/t.csv", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr(fmt::format("{}/broken.avi", dir)));
  EXPECT_THAT(o.output, ::testing::AnyOf(HasSubstr("not a video"), HasSubstr("no frame decodes")));
  o = RunCliBounded(fmt::format("track --source {0}/broken.avi --grid 8by10", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--grid '8by10' must be ROWSxCOLS"));
  EXPECT_FALSE(fs::exists(dir + "/t.csv"));
}

// One rule for every output: never over an input, never a device, a pipe or a link replaced or
// written through; and the counts a user gives bounded before any work.
TEST(Cli, OutputsAreNeverAnInputADeviceOrALink) {
  const std::string dir = testing::MakeTempDir("output_rule");
  std::ofstream(dir + "/v.avi") << "RIFF....AVI LIST: the user's video";
  Outcome o = RunCliBounded(fmt::format("track --source {0}/v.avi --out {0}/v.avi", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr(fmt::format("--out '{0}/v.avi' is the input '{0}/v.avi'", dir)));
  std::ifstream video(dir + "/v.avi");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(video), {}), "RIFF....AVI LIST: the user's video");
  // The vendor's own sensor.yaml, by the default --out in its folder.
  fs::create_directories(dir + "/vendor");
  std::ofstream(dir + "/vendor/sensor.yaml") << "SN: X\n";
  o = RunCli("import-vendor .", fmt::format("cd {}/vendor && timeout -s KILL 20 ", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--out 'sensor.yaml' would replace a file inside the input folder '.'"));
  // A character device is refused, never renamed over (as root, /dev/null would have become a file).
  o = RunCliBounded("design --out /dev/null");
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--out '/dev/null' is not a regular file"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  fs::create_symlink(dir + "/v.avi", dir + "/link.yaml");
  o = RunCliBounded(fmt::format("design --out {}/link.yaml", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("is a symbolic link"));
}

TEST(Cli, CountsAndFrameRangesAreBoundedUpFront) {
  const std::string dir = testing::MakeTempDir("counts");
  std::ofstream(dir + "/v.avi") << "not a video";
  Outcome o = RunCliBounded(fmt::format("track --source {}/v.avi --grid 1000x1000", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--grid '1000x1000': at most 100 x 100 markers"));
  o = RunCliBounded(fmt::format("track --source {}/v.avi --rest-frames 0:99999999999", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("'0:99999999999': a frame number has at most 9 digits"));
  // A link loop is a file that cannot be looked at, said as such.
  fs::create_symlink(dir + "/loop", dir + "/loop");
  o = RunCliBounded(fmt::format("track --source {}/loop", dir));
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, Not(HasSubstr("unexpected error")));
  EXPECT_THAT(o.output, HasSubstr("loop"));
}

}  // namespace
}  // namespace tac3d
