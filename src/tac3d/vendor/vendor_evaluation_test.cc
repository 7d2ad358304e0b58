#include "tac3d/vendor/vendor_evaluation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor/test_vendor_folder.h"

namespace tac3d {
namespace {

namespace fixture = testing::hdl1_0001;
using ::testing::HasSubstr;

// A recording of the fixture's sensor whose frame 0 holds the fixture's reference positions
// (as positions - displacements) and frame 1 the same moved 1 mm in z.
VendorRecording FixtureRecording() {
  VendorRecording r;
  r.serial_number = "HDL1-0001";
  std::vector<double> positions, displacements;
  for (int frame = 0; frame < 2; ++frame) {
    for (const auto& p : fixture::kReferencePositionsMm) {
      for (int k = 0; k < 3; ++k) {
        const double d = frame == 1 && k == 2 ? -1.0 : 0.01 * k;
        positions.push_back(p[k] + d);
        displacements.push_back(d);
      }
    }
  }
  const auto array = [](std::vector<std::int64_t> shape, const std::vector<double>& values) {
    NpyArray a;
    a.shape = std::move(shape);
    a.data.assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
    return a;
  };
  r.positions = array({2, 400, 3}, positions);
  r.displacements = array({2, 400, 3}, displacements);
  r.forces = array({2, 400, 3}, std::vector<double>(2400, 0.0));
  r.resultant_force = array({2, 1, 3}, std::vector<double>(6, 0.0));
  r.resultant_moment = r.resultant_force;
  r.send_timestamp = array({2}, {0.0, 0.033});
  r.index.type = NpyType::kInt64;
  r.index.shape = {2};
  r.index.data.assign(16, '\0');
  return r;
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

}  // namespace
}  // namespace tac3d
