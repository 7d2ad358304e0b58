// `tac3d run --udp` as the vendor's C++ client (SDK 3.2.1) receives it: every frame
// measured after the initialisation is delivered, and nothing is complained about with the
// default items; with `--udp-items all` the extra items arrive (and that client complains
// about each, every frame). The receiver is testing::VendorCppClient, a mimic written from
// docs/pipeline.md's facts; the source, rendered images of a 3 x 3-marker sensor whose model
// builds in seconds, runs through the real CLI and pipeline.
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <vector>

#include "tac3d/protocol/test_vendor_client.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d::vendor_clients_test {
namespace {

constexpr int kImages = 12;
constexpr int kReferenceFrames = 4;

// A folder of kImages rendered undeformed images, the sensor's config and a model cache, made
// once for the file.
struct Source {
  std::string dir, config, images, cache;
};
const Source& SmallSource() {
  static const Source source = [] {
    const std::string dir = testing::MakeTempDir("vendor_clients");
    Source s{dir, dir + "/small.yaml", dir + "/images", dir + "/cache"};
    const SensorConfig sensor = testing::SmallSensor();
    SaveSensorConfig(sensor, s.config);
    std::filesystem::create_directories(s.images);
    const MarkerImageRenderer renderer(sensor);
    for (int k = 0; k < kImages; ++k) {
      cv::imwrite(fmt::format("{}/{:03d}.png", s.images, k),
                  renderer.Render(sensor.MarkerPositions(), k));
    }
    return s;
  }();
  return source;
}

struct StreamRun {
  int exit_code = -1;
  std::vector<std::int64_t> measured;  // the --json lines' indices with initialize_progress 100
  int frames = 0;                      // --json lines
  std::string log;                     // stderr
};

// `tac3d run` on the small source to 127.0.0.1:port, with `flags`; the client is bound
// before it starts.
StreamRun RunStream(std::uint16_t port, const std::string& flags) {
  const Source& s = SmallSource();
  const std::string log = fmt::format("{}/run_{}.log", s.dir, port);
  const std::string command = fmt::format(
      "{} run --source {} --config {} --cache {} --reference-frames {} --sn VENDOR-3x3 --json "
      "--udp 127.0.0.1:{} {} 2>{}",
      TAC3D_CLI_PATH,
      s.images,
      s.config,
      s.cache,
      kReferenceFrames,
      port,
      flags,
      log);
  StreamRun run;
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  char line[4096];
  while (std::fgets(line, sizeof(line), pipe) != nullptr) {
    const nlohmann::json frame = nlohmann::json::parse(line);
    ++run.frames;
    if (frame["initialize_progress"] == 100) run.measured.push_back(frame["index"]);
  }
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(log);
  run.log.assign(std::istreambuf_iterator<char>(in), {});
  return run;
}

TEST(VendorCppClient, ReceivesEveryMeasuredFrameAndComplainsOfNothingByDefault) {
  testing::VendorCppClient client;
  const StreamRun run = RunStream(client.port(), "");
  ASSERT_EQ(run.exit_code, 0) << run.log;
  ASSERT_EQ(run.frames, kImages) << run.log;
  // The reference is taken on kReferenceFrames frames, the last of which is measured.
  ASSERT_EQ(run.measured.size(), kImages - kReferenceFrames + 1) << run.log;
  client.ReceiveUntilIdle(0.5, 10.0);
  EXPECT_EQ(client.delivered(), run.measured) << run.log;
  EXPECT_EQ(client.complaints(), 0) << ::testing::PrintToString(client.unknown_items());
  // Nothing is sent while initialising: every frame that arrived was delivered.
  EXPECT_EQ(client.frames_completed(), static_cast<int>(run.measured.size()));
  EXPECT_EQ(client.matrix_bytes("3D_Positions"), 9 * 3 * sizeof(double));
  EXPECT_EQ(client.matrix_bytes("3D_ResultantMoment"), 3 * sizeof(double));
  EXPECT_THAT(run.log, ::testing::HasSubstr(fmt::format("{} streamed", run.measured.size())));
}

TEST(VendorCppClient, TheExtraItemsArriveWhenAskedAndItComplainsOfEachEveryFrame) {
  testing::VendorCppClient client;
  const StreamRun run = RunStream(client.port(), "--udp-items all");
  ASSERT_EQ(run.exit_code, 0) << run.log;
  client.ReceiveUntilIdle(0.5, 10.0);
  EXPECT_EQ(client.delivered(), run.measured) << run.log;
  const std::set<std::string> extras = {
      "3D_Normals", "SlipState", "SlipFraction", "Friction", "FrictionSigma", "SlipMargin"};
  EXPECT_EQ(client.unknown_items(), extras);
  EXPECT_EQ(client.complaints(), 6 * client.frames_completed());
}

TEST(VendorCppClient, ProgressFramesWhenAskedAreSentAndSkippedByTheClient) {
  testing::VendorCppClient client;
  const StreamRun run = RunStream(client.port(), "--udp-progress");
  ASSERT_EQ(run.exit_code, 0) << run.log;
  client.ReceiveUntilIdle(0.5, 10.0);
  EXPECT_EQ(client.frames_completed(), kImages);
  EXPECT_EQ(client.delivered(), run.measured) << run.log;
  EXPECT_EQ(client.complaints(), 0);
}

}  // namespace
}  // namespace tac3d::vendor_clients_test
