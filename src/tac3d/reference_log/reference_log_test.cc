#include "tac3d/reference_log/reference_log.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "tac3d/record/recording.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A press session on the reference's clock: five presses of different size and direction,
// each a 0.5 s ramp up, a 1 s hold, a 0.5 s ramp down and 1 s at rest, from t = 1 s.
constexpr double kPressPeriodS = 3.0, kFirstPressS = 1.0;
const std::vector<Eigen::Vector3d> kPressForces = {
    {0.0, 0.0, -2.0}, {0.8, -0.3, -5.0}, {-1.5, 0.6, -8.0}, {0.2, 1.2, -3.5}, {0.0, -2.0, -6.5}};

Eigen::Vector3d TrueForce(double t) {
  const double local = t - kFirstPressS;
  if (local < 0.0) return Eigen::Vector3d::Zero();
  const int press = static_cast<int>(local / kPressPeriodS);
  if (press >= static_cast<int>(kPressForces.size())) return Eigen::Vector3d::Zero();
  const double s = local - press * kPressPeriodS;
  const double level = s < 0.5 ? s / 0.5 : s < 1.5 ? 1.0 : s < 2.0 ? (2.0 - s) / 0.5 : 0.0;
  return level * kPressForces[press];
}

// The reference log at 1 kHz: every kink of TrueForce falls on a sample, so linear
// interpolation gives TrueForce exactly.
std::vector<ReferenceSample> MakeLog() {
  std::vector<ReferenceSample> log;
  for (int k = 0; k <= 17000; ++k) log.push_back({k * 1e-3, TrueForce(k * 1e-3)});
  return log;
}

constexpr double kOffsetS = 2.3456;      // recording time = reference time + this
constexpr double kSensorScale = 0.9;     // the sensor reads 10% low with unit gains
const Eigen::Vector3d kGainsUsed(1.1, 1.2, 0.95);
constexpr int kLogRows = 3, kLogCols = 4;

// A recording at 30 fps of a sensor whose resultant is kSensorScale x the force (times the
// gains it was run with) and whose displacements are a fixed pattern times the force.
// `damage(frame)` may flag a frame or invalidate a marker.
std::string WriteRecording(const std::string& dir, const std::function<void(TactileFrame*)>& damage) {
  const std::string path = dir + "/session.t3r";
  RecordingWriter writer(path);
  for (int k = 0; k < 540; ++k) {
    TactileFrame frame = TactileFrame::Sized(kLogRows, kLogCols);
    frame.index = k;
    frame.timestamp_s = kOffsetS + 0.2 + k / 30.0;
    const Eigen::Vector3d force = TrueForce(frame.timestamp_s - kOffsetS);
    frame.resultant_force_n = kSensorScale * force.cwiseProduct(kGainsUsed);
    for (int i = 0; i < kLogRows * kLogCols; ++i) {
      frame.displacements_mm[i] = 0.01 * (i + 1) * force;
    }
    damage(&frame);
    writer.Write(frame);
  }
  return path;
}

ReferenceJoinOptions Options() {
  ReferenceJoinOptions options;
  options.gains_used = kGainsUsed;
  return options;
}

TEST(JoinRecordingWithReference, FindsTheOffsetAndPairsTheSteadyPresses) {
  const std::string path = WriteRecording(testing::MakeTempDir("join"), [](TactileFrame*) {});
  const ReferenceJoin join = JoinRecordingWithReference(path, MakeLog(), Options());
  EXPECT_TRUE(join.offset_estimated);
  EXPECT_NEAR(join.time_offset_s, kOffsetS, 0.001);
  EXPECT_GT(join.correlation, 0.999);
  EXPECT_EQ(join.frames, 540);
  EXPECT_EQ(join.recording_status, "complete");
  // Every hold frame (1 s at 30 fps, 5 presses: 150) and the ramps' frames slower than 10 N/s.
  ASSERT_GE(join.pairs.size(), 145u);
  ASSERT_EQ(join.pairs.size(), join.presses.size());
  ASSERT_EQ(join.pairs.size(), join.frame_indices.size());
  EXPECT_GT(join.skipped.below_force, 0);
  EXPECT_GT(join.skipped.changing, 0);  // the 16 N/s ramps of the 8 N press
  for (size_t k = 0; k < join.pairs.size(); ++k) {
    const double t = join.frame_indices[k] / 30.0 + 0.2;  // on the reference's clock
    // The reference at the frame's time, off by at most the offset's error times the rate.
    EXPECT_LT((join.pairs[k].reference_n - TrueForce(t)).norm(), 0.011) << "frame " << k;
    EXPECT_LT((join.pairs[k].measured_n - kSensorScale * TrueForce(t)).norm(), 1e-9);
    // Displacements in the presses' order: dx of every marker, then dy, then dz.
    const Eigen::VectorXd& d = join.presses[k].displacement_mm;
    ASSERT_EQ(d.size(), 3 * kLogRows * kLogCols);
    EXPECT_NEAR(d(kLogRows * kLogCols + 2), 0.03 * TrueForce(t).y(), 1e-12);
  }
  // The gains the pairs give undo the sensor's 10% shortfall.
  const ForceGainFit fit = FitForceGains(join.pairs);
  EXPECT_NEAR(fit.gains.x(), 1.0 / kSensorScale, 0.005);
  EXPECT_NEAR(fit.gains.y(), 1.0 / kSensorScale, 0.005);
  EXPECT_NEAR(fit.gains.z(), 1.0 / kSensorScale, 0.002);
}

TEST(JoinRecordingWithReference, SkipsFlaggedFramesAndLostMarkers) {
  const std::string path =
      WriteRecording(testing::MakeTempDir("damaged"), [](TactileFrame* frame) {
        if (frame->index % 10 == 3) frame->set(FrameFlag::kLightingChanged);
        if (frame->index % 10 == 5) frame->valid[7] = false;
        if (frame->index % 10 == 7) frame->set(FrameFlag::kZeroed);  // not a reason to skip
      });
  const ReferenceJoin clean =
      JoinRecordingWithReference(WriteRecording(testing::MakeTempDir("clean"), [](TactileFrame*) {}),
                                 MakeLog(), Options());
  const ReferenceJoin join = JoinRecordingWithReference(path, MakeLog(), Options());
  EXPECT_GT(join.skipped.flagged, 10);
  EXPECT_GT(join.skipped.invalid_markers, 10);
  EXPECT_EQ(join.pairs.size() + join.skipped.flagged + join.skipped.invalid_markers,
            clean.pairs.size());
  for (std::int64_t index : join.frame_indices) {
    EXPECT_NE(index % 10, 3);
    EXPECT_NE(index % 10, 5);
  }
}

TEST(JoinRecordingWithReference, UsesAGivenOffsetAndRefusesAnUnrelatedLog) {
  const std::string path = WriteRecording(testing::MakeTempDir("given"), [](TactileFrame*) {});
  ReferenceJoinOptions options = Options();
  options.time_offset_s = kOffsetS;
  const ReferenceJoin join = JoinRecordingWithReference(path, MakeLog(), options);
  EXPECT_FALSE(join.offset_estimated);
  EXPECT_EQ(join.time_offset_s, kOffsetS);
  EXPECT_GT(join.correlation, 0.999);

  // Another session's log (the presses in another order): nothing correlates well enough.
  std::vector<ReferenceSample> other = MakeLog();
  for (ReferenceSample& s : other) s.force_n = TrueForce(std::fmod(s.t_s * 7.3, 17.0));
  try {
    JoinRecordingWithReference(path, other, Options());
    FAIL() << "an unrelated log was joined";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("give the offset"), std::string::npos) << e.what();
  }
}

TEST(ReferenceLog, ParsesAndRefusesTimesThatDoNotIncrease) {
  const std::vector<ReferenceSample> log =
      ParseReferenceLog("# rig log\nt_s, fx_n, fy_n, fz_n\n0.0,0,0,0\n0.001, 0.1, 0.2, -1.5\n");
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[1].force_n, Eigen::Vector3d(0.1, 0.2, -1.5));
  EXPECT_THROW(ParseReferenceLog("t_s,fx_n,fy_n,fz_n\n0.0,0,0,0\n0.0,1,1,1\n"), Error);
  EXPECT_THROW(ParseReferenceLog("t_s,fx_n,fy_n,fz_n\n0.0,0,0,0\n"), Error);
  EXPECT_THROW(ParseReferenceLog("time,fx,fy,fz\n0.0,0,0,0\n1,0,0,0\n"), Error);
  EXPECT_THROW(ParseReferenceLog("t_s,fx_n,fy_n,fz_n\n0.0,0,0,0\n1,nan,0,0\n"), Error);
}

TEST(ReferenceJoinOptions, EveryBoundIsChecked) {
  EXPECT_NO_THROW(ReferenceJoinOptions{}.Validate());
  const auto expect_throw = [](auto change) {
    ReferenceJoinOptions options;
    change(options);
    EXPECT_THROW(options.Validate(), Error);
  };
  expect_throw([](ReferenceJoinOptions& o) { o.time_offset_s = NAN; });
  expect_throw([](ReferenceJoinOptions& o) { o.max_offset_s = -1.0; });
  expect_throw([](ReferenceJoinOptions& o) { o.min_correlation = 0.0; });
  expect_throw([](ReferenceJoinOptions& o) { o.min_force_n = 0.0; });
  expect_throw([](ReferenceJoinOptions& o) { o.max_rate_n_per_s = 0.0; });
  expect_throw([](ReferenceJoinOptions& o) { o.gains_used.y() = 0.0; });
  // Issue 22, defect 11: +-1e9 s was accepted, and the error then claimed a search of it.
  ReferenceJoinOptions wide;
  wide.max_offset_s = 1e9;
  EXPECT_THAT([&] { wide.Validate(); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "ReferenceJoinOptions: max_offset_s = 1000000000 must be in [0, 600] s")));
  wide.max_offset_s = kMaxSearchedOffsetS;
  EXPECT_NO_THROW(wide.Validate());
}

}  // namespace
}  // namespace tac3d
