// A `$C` (zero) from the client while the sensor is loaded: zeroing then takes the
// load for the undeformed state and offsets every later reading, so it is refused unless the
// run allows it; at rest it zeroes quietly. Real sockets on 127.0.0.1, ephemeral ports.
#include "tac3d/runtime/run_outputs.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "tac3d/protocol/client.h"

namespace tac3d::runtime {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// A bound on a hang, not a timing assertion.
constexpr double kWaitS = 5.0;

// Drift at rest: every marker 0.02 mm along -z, which the inverse reads as a phantom 1.5 N
// (a uniform creep of 0.04 mm read 1.5 N in docs/pipeline.md).
TactileFrame AtRest() {
  TactileFrame frame = TactileFrame::Sized(20, 20);
  for (Eigen::Vector3d& d : frame.displacements_mm) d = Eigen::Vector3d(0, 0, -0.02);
  frame.resultant_force_n = Eigen::Vector3d(0, 0, -1.5);
  return frame;
}

// Mid-contact, as vendor_style.py's zero on two_material_slide: F about (-2.36, 0, -3.57) N,
// the markers under the block pushed in and dragged.
TactileFrame Loaded() {
  TactileFrame frame = AtRest();
  frame.index = 5;
  for (int i = 180; i < 190; ++i) frame.displacements_mm[i] = Eigen::Vector3d(-0.2, 0, -0.4);
  frame.resultant_force_n = Eigen::Vector3d(-2.36, 0, -3.57);
  return frame;
}

TEST(MeasureZeroLoad, ALoadIsADisplacementBeyondTheBandNotAPhantomForce) {
  const ZeroLoad rest = MeasureZeroLoad(AtRest());
  EXPECT_FALSE(rest.under_load);
  EXPECT_NEAR(rest.max_displacement_mm, 0.02, 1e-12);
  EXPECT_NEAR(rest.force_n, 1.5, 1e-12);
  const ZeroLoad loaded = MeasureZeroLoad(Loaded());
  EXPECT_TRUE(loaded.under_load);
  EXPECT_NEAR(loaded.max_displacement_mm, std::hypot(0.2, 0.4), 1e-12);
  EXPECT_NEAR(loaded.force_n, std::hypot(2.36, 3.57), 1e-12);
  // An invalid marker's displacement (NaN, or whatever it holds) is not a load.
  TactileFrame lost = AtRest();
  lost.valid[7] = false;
  lost.displacements_mm[7] = Eigen::Vector3d(5, 5, 5);
  EXPECT_FALSE(MeasureZeroLoad(lost).under_load);
}

struct ZeroRun {
  int zeros = 0;  ///< on_zero calls
  bool quit = false;
  std::string log;  ///< stderr
};

// FrameLoop streaming one frame at rest, then `frame` again and again; the client answers the
// first with `$C` then `$Q`, so the loop has handled the `$C` (after a `frame`) when it quits.
ZeroRun ZeroAfter(const TactileFrame& frame, bool allow_zero_under_load) {
  Client client({.bind_address = "127.0.0.1", .port = 0});
  FrameOutputArgs args;
  args.udp = fmt::format("127.0.0.1:{}", client.local_endpoint().port);
  args.udp_progress = true;
  args.sn = "AD2-0065L";
  args.allow_zero_under_load = allow_zero_under_load;
  ZeroRun run;
  ::testing::internal::CaptureStderr();
  {
    FrameOutputs outputs(args);
    const TactileFrame rest = AtRest();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kWaitS);
    long calls = 0;
    std::atomic<bool> stop{false};
    const FrameLoopCounts counts = FrameLoop(
        outputs, 0, stop,
        [&](const std::atomic<bool>&, ProducedFrame& out) {
          if (std::chrono::steady_clock::now() > deadline) return Produced::kEnd;
          if (calls == 1) {
            const std::optional<ReceivedFrame> received = client.Receive(kWaitS);
            if (!received) return Produced::kEnd;
            client.SendCommand(received->sender, SensorCommand::kZero);
            client.SendCommand(received->sender, SensorCommand::kStop);
          } else if (calls > 1) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
          }
          out.frame = calls++ == 0 ? &rest : &frame;
          return Produced::kFrame;
        },
        {[&] { ++run.zeros; }});
    run.quit = counts.quit;
  }
  run.log = ::testing::internal::GetCapturedStderr();
  return run;
}

TEST(FrameLoop, AZeroAtRestIsTakenQuietly) {
  const ZeroRun run = ZeroAfter(AtRest(), false);
  ASSERT_TRUE(run.quit) << run.log;
  EXPECT_EQ(run.zeros, 1);
  EXPECT_THAT(run.log, Not(HasSubstr("load")));
}

TEST(FrameLoop, AZeroUnderLoadIsRefusedNamingTheLoad) {
  const ZeroRun run = ZeroAfter(Loaded(), false);
  ASSERT_TRUE(run.quit) << run.log;
  EXPECT_EQ(run.zeros, 0);
  EXPECT_THAT(run.log, HasSubstr("AD2-0065L: refused $C (zero) under load: |F| = 4.28 N, a marker "
                                 "displaced 0.447 mm (more than 0.1 mm) at frame 5"));
  EXPECT_THAT(run.log, HasSubstr("--allow-zero-under-load"));
}

TEST(FrameLoop, AZeroUnderLoadIsTakenWithAWarningWhenAllowed) {
  const ZeroRun run = ZeroAfter(Loaded(), true);
  ASSERT_TRUE(run.quit) << run.log;
  EXPECT_EQ(run.zeros, 1);
  EXPECT_THAT(run.log, HasSubstr("AD2-0065L: warning: zero taken under load (--allow-zero-under-load): "
                                 "|F| = 4.28 N"));
}

}  // namespace
}  // namespace tac3d::runtime
