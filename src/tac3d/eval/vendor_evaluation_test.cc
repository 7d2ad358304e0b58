#include "tac3d/eval/vendor_evaluation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

namespace tac3d {
namespace {

namespace fixture = testing::hdl1_0001;
using ::testing::HasSubstr;

using testing::FixtureForceRecording;
using testing::FixtureRecording;

// The force part's options in these tests: a coarse mesh (the CLI's default refinement is 1),
// built once and cached for the other tests.
VendorForceOptions TestForceOptions() {
  static const std::string cache_dir = testing::MakeTempDir("vendor_force_cache");
  return {.gel = {.refinement = 0.5}, .cache_dir = cache_dir};
}

TEST(VendorEvaluation, ForcesOfTheFixtureFramesWithinTenPercent) {
  const SensorConfig config = testing::FixtureVendorSensor();
  VendorEvaluationOptions options;
  options.forces = TestForceOptions();
  const VendorEvaluation e = EvaluateVendorRecording(config, FixtureForceRecording(), options);
  ASSERT_TRUE(e.forces);
  const VendorForceEvaluation& f = *e.forces;
  EXPECT_TRUE(e.all_pass) << e.Report();
  ASSERT_EQ(e.checks.size(), 4u);
  EXPECT_EQ(e.checks[3].name, "resultant_magnitude_error_median_pct");
  EXPECT_EQ(f.frames_compared, 2);
  EXPECT_LE(f.tac3d.magnitude_pct.median, 10.0) << e.Report();
  // The press is along -z: the estimate too, with little x and y.
  EXPECT_LT(f.tac3d.median_resultant_n.z(), -4.8);
  EXPECT_LT(f.tac3d.axis_pct[0].max, 10.0);
  EXPECT_LT(f.tac3d.axis_pct[1].max, 10.0);
  // The vendor's per-marker forces sum to 1.23 x its resultant (docs/real-sensors.md).
  EXPECT_NEAR(f.vendor_marker_sum.median_magnitude_ratio, 1.227, 0.005);
  EXPECT_NEAR(f.vendor_marker_sum.median_resultant_n.z(), -6.59, 0.02);
  // The inverse checked is `tac3d run`'s for an imported sensor: F = K D at w 0.05.
  EXPECT_EQ(f.inverse.weight, 0.05);
  EXPECT_FALSE(f.inverse.support_refinement);
  EXPECT_GT(f.discrepancy_weight.weight, 0.0);
  EXPECT_TRUE(f.discrepancy_weight.summary.converged) << f.discrepancy_weight.summary.message;
  const nlohmann::json json = ToJson(e);
  EXPECT_EQ(json["resultant_error_pct"]["magnitude"]["median"], f.tac3d.magnitude_pct.median);
  EXPECT_EQ(json["resultant_error_pct"]["z"]["count"], 2);
  EXPECT_EQ(json["vendor_marker_sum_error_pct"]["magnitude"]["median"], f.vendor_marker_sum.magnitude_pct.median);
  EXPECT_EQ(json["gel"]["body"]["thickness_mm"], f.body.thickness_mm);
  EXPECT_EQ(json["frames_compared"], 2);
  EXPECT_EQ(json["inverse"]["weight"], 0.05);
  EXPECT_EQ(json["inverse"]["support_resolve"], false);
  EXPECT_EQ(json["inverse"]["sensor_defaults"], true);
  EXPECT_THAT(e.Report(), HasSubstr("tac3d's forces: median |F| / |R|"));
  EXPECT_THAT(e.Report(), HasSubstr("(its defaults): Tikhonov weight 0.05 (mm/N)^2, contact-support re-solve off"));
}

// The fixture's pressed frame at four depths (displacements and recorded resultant scaled
// alike, as a linear gel would): the recording determines Cz, whose gain makes tac3d's
// resultant the recorded one.
TEST(VendorEvaluation, GainsFromAVendorRecordingOnTheAxesItDetermines) {
  const SensorConfig config = testing::FixtureVendorSensor();
  const VendorRecording two = FixtureForceRecording();
  VendorRecording r = two;
  const std::vector<double> scales = {0.5, 0.75, 1.0, 1.25};
  std::vector<double> positions, displacements, forces, resultants, times;
  const Eigen::MatrixX3d p1 = VendorRecording::Frame(two.positions, 1), d1 = VendorRecording::Frame(two.displacements, 1);
  const Eigen::MatrixX3d f1 = VendorRecording::Frame(two.forces, 1);
  const Eigen::Vector3d r1 = VendorRecording::Frame(two.resultant_force, 1).row(0).transpose();
  for (size_t k = 0; k < scales.size(); ++k) {
    for (int i = 0; i < 400; ++i) {
      for (int a = 0; a < 3; ++a) {
        positions.push_back(p1(i, a) - d1(i, a) + scales[k] * d1(i, a));
        displacements.push_back(scales[k] * d1(i, a));
        forces.push_back(scales[k] * f1(i, a));
      }
    }
    for (int a = 0; a < 3; ++a) resultants.push_back(scales[k] * r1(a));
    times.push_back(0.1 * k);
  }
  const std::int64_t t = static_cast<std::int64_t>(scales.size());
  r.positions = testing::DoubleArray({t, 400, 3}, positions);
  r.displacements = testing::DoubleArray({t, 400, 3}, displacements);
  r.forces = testing::DoubleArray({t, 400, 3}, forces);
  r.resultant_force = testing::DoubleArray({t, 1, 3}, resultants);
  r.resultant_moment = r.resultant_force;
  r.send_timestamp = testing::DoubleArray({t}, times);
  r.index.shape = {t};
  r.index.data.assign(static_cast<size_t>(t) * 8, '\0');
  const VendorGainCalibration c = CalibrateGainsOnVendorRecording(config, r, TestForceOptions());
  EXPECT_EQ(c.frames_compared, 4);
  EXPECT_FALSE(c.inverse.support_refinement);
  // Cz: the recorded over tac3d's (0.945 of it on these frames, as the check above measures).
  EXPECT_EQ(c.fit.left_at_one[2], "");
  EXPECT_GT(c.fit.gains.z(), 1.03);
  EXPECT_LT(c.fit.gains.z(), 1.09);
  EXPECT_GT(c.fit.r_squared.z(), 0.999);
  // tac3d's fx has the other sign than the recorded -0.02 N: left at 1, saying so.
  EXPECT_EQ(c.fit.gains.x(), 1.0);
  EXPECT_THAT(c.fit.left_at_one[0], HasSubstr("disagree in sign"));
  // Two frames are too few to fit anything.
  EXPECT_THAT([&] { CalibrateGainsOnVendorRecording(config, two, TestForceOptions()); },
              ::testing::ThrowsMessage<Error>(HasSubstr("fitting gains needs at least 3")));
}

TEST(VendorEvaluation, ForcesFailWhenTheDisplacementsAreHalvedAndNotApplicableWithoutLoad) {
  const SensorConfig config = testing::FixtureVendorSensor();
  // Half the displacements for the same recorded resultant: a linear model's forces halve.
  VendorRecording halved = FixtureForceRecording();
  auto* d = reinterpret_cast<double*>(halved.displacements.data.data());
  for (int i = 0; i < 2400; ++i) d[i] *= 0.5;
  VendorEvaluationOptions options;
  options.forces = TestForceOptions();
  const VendorEvaluation soft = EvaluateVendorRecording(config, halved, options);
  EXPECT_FALSE(soft.all_pass);
  EXPECT_LT(soft.forces->tac3d.median_magnitude_ratio, 0.6);
  // No frame over the limit: nothing compared, the check does not apply.
  options.forces->min_resultant_n = 6.0;
  const VendorEvaluation unloaded = EvaluateVendorRecording(config, FixtureForceRecording(), options);
  EXPECT_EQ(unloaded.forces->frames_compared, 0);
  EXPECT_FALSE(unloaded.checks[3].applicable);
  EXPECT_TRUE(unloaded.all_pass);
  options.forces->min_resultant_n = -1.0;
  EXPECT_THROW(EvaluateVendorRecording(config, FixtureForceRecording(), options), Error);
}

// A NaN displacement in the reference frame still gave 400 markers, all passing: the reference
// must be whole, and force frames holding one are left out and counted.
TEST(VendorEvaluation, ValuesThatAreNotNumbersAreNeverCompared) {
  const SensorConfig config = testing::FixtureVendorSensor();
  VendorRecording r = FixtureForceRecording();
  auto* d = reinterpret_cast<double*>(r.displacements.data.data());
  d[(400 + 5) * 3] = std::numeric_limits<double>::quiet_NaN();  // frame 1, marker 5, x
  VendorEvaluationOptions options;
  options.forces = TestForceOptions();
  const VendorEvaluation e = EvaluateVendorRecording(config, r, options);
  EXPECT_EQ(e.forces->frames_compared, 1);
  EXPECT_EQ(e.forces->frames_not_finite, 1);
  EXPECT_THAT(e.Report(), HasSubstr("(1 more left out: a NaN or an infinity in a marker or the resultant)"));
  d[5 * 3] = std::numeric_limits<double>::quiet_NaN();  // frame 0, the reference
  EXPECT_THAT([&] { EvaluateVendorRecording(config, r, options); },
              ::testing::ThrowsMessage<Error>(HasSubstr("reference frame 0: marker 5's position, displacement or "
                                                        "force is not a finite number")));
}

TEST(VendorEvaluation, ReferencePositionsOfTheFixturePass) {
  const VendorEvaluation e = EvaluateVendorRecording(testing::FixtureVendorSensor(), FixtureRecording());
  EXPECT_TRUE(e.all_pass) << e.Report();
  EXPECT_LE(e.reference_position_error_mm.median, 0.06);
  EXPECT_LE(e.reference_position_error_mm.max, 0.15);
  EXPECT_LE(e.reference_position_error_mm.median, e.reference_position_error_mm.p95);
  EXPECT_LE(e.reference_position_error_mm.p95, e.reference_position_error_mm.max);
  EXPECT_EQ(e.reference_position_error_mm.count, 400);
  EXPECT_EQ(e.frames, 2);
  const nlohmann::json json = ToJson(e);
  EXPECT_EQ(json["reference_position_error_mm"]["median"], e.reference_position_error_mm.median);
  EXPECT_EQ(json["pass"], true);
  EXPECT_EQ(json["checks"].size(), 3u);
  EXPECT_THAT(e.Report(), HasSubstr("reference position error: median"));
}

TEST(VendorEvaluation, FailsWhereTheModelDoesNot) {
  const SensorConfig config = testing::FixtureVendorSensor();
  // Frame 1's reference is the same as frame 0's: positions and displacements both moved.
  EXPECT_TRUE(EvaluateVendorRecording(config, FixtureRecording(), {.reference_frame = 1}).all_pass);
  const VendorEvaluation straight =
      EvaluateVendorRecording(config, FixtureRecording(), {.stereo = {.undistort = true, .refract = false}});
  EXPECT_FALSE(straight.all_pass);
  EXPECT_GT(straight.reference_position_error_mm.median, 2.0);
  // A recording whose reference is off by 1 mm (positions moved, displacements not).
  VendorRecording moved = FixtureRecording();
  auto* values = reinterpret_cast<double*>(moved.positions.data.data());
  for (int i = 0; i < 1200; ++i) values[i] += i % 3 == 2 ? 1.0 : 0.0;
  EXPECT_NEAR(EvaluateVendorRecording(config, moved).reference_position_error_mm.median, 1.0, 0.06);
}

TEST(VendorEvaluation, RefusesAnotherSensorsRecording) {
  const SensorConfig config = testing::FixtureVendorSensor();
  VendorRecording r = FixtureRecording();
  r.serial_number = "YA1-007";
  EXPECT_THROW(
      {
        try {
          EvaluateVendorRecording(config, r);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("the recording is of sensor 'YA1-007', the config of sensor 'HDL1-0001'"));
          throw;
        }
      },
      Error);
  EXPECT_THROW(EvaluateVendorRecording(config, FixtureRecording(), {.reference_frame = 2}), Error);
}

// Issue 23's acceptance on the real sensor: median <= 0.06 mm, max <= 0.15 mm.
TEST(VendorEvaluation, RealHdl1CalibrationAgainstItsRecording) {
  TAC3D_REQUIRE_REALDATA(realdata);
  const SensorConfig config = ImportVendorSensor(realdata + "/tac3d/HDL1-0001/config");
  const VendorEvaluation e = EvaluateVendorRecording(
      config, ReadVendorRecording(realdata + "/tac3d/HDL1-0001/recording/Tac3D_Record_20241227_161029"));
  EXPECT_TRUE(e.all_pass) << e.Report();
  EXPECT_NEAR(e.reference_position_error_mm.median, 0.044, 0.002);
  EXPECT_NEAR(e.reference_position_error_mm.max, 0.12, 0.005);
}

// Issue 23's force acceptance on the real recording, all 64 frames, the CLI's gel on a coarser
// mesh (5.3 % there, 6.3 % at the CLI's refinement 1: docs/real-sensors.md).
TEST(VendorEvaluation, RealHdl1ForcesWithinTenPercent) {
  TAC3D_REQUIRE_REALDATA(realdata);
  const SensorConfig config = ImportVendorSensor(realdata + "/tac3d/HDL1-0001/config");
  VendorEvaluationOptions options;
  options.forces = TestForceOptions();
  const VendorEvaluation e = EvaluateVendorRecording(
      config, ReadVendorRecording(realdata + "/tac3d/HDL1-0001/recording/Tac3D_Record_20241227_161029"), options);
  EXPECT_TRUE(e.all_pass) << e.Report();
  EXPECT_EQ(e.forces->frames_compared, 64);
  EXPECT_LE(e.forces->tac3d.magnitude_pct.median, 10.0);
}

}  // namespace
}  // namespace tac3d
