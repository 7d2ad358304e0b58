#include "tac3d/vendor_formats/vendor_gel.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/fem/compliance.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

std::string Refusal(const SensorConfig& config, const VendorGelOptions& options) {
  try {
    VendorBodyModelOptions(config, options);
  } catch (const Error& e) {
    return e.what();
  }
  return "accepted";
}

TEST(VendorGel, FixtureBodyIsTheFittedDomeOnTheRefractionPlane) {
  const SensorConfig config = testing::FixtureVendorSensor();
  const DomeFitConfig& dome = config.vendor_camera->dome;
  const fem::BodyModelOptions body = VendorBodyModelOptions(config);
  // The base on the refraction plane (h0 = 0) under the fitted centre; the outer surface the
  // markers' sphere grown by 0.5 mm.
  EXPECT_EQ(body.base_center_mm, Eigen::Vector3d(dome.center_mm.x(), dome.center_mm.y(), 0.0));
  EXPECT_DOUBLE_EQ(body.sphere_radius_mm, dome.radius_mm + 0.5);
  EXPECT_NEAR(body.thickness_mm, dome.center_mm.z() + dome.radius_mm + 0.5, 1e-12);
  EXPECT_NEAR(body.thickness_mm, 10.05, 0.05);  // HDL1-0001: markers up to 9.56 mm over the plane
  EXPECT_NEAR(body.base_diameter_mm, 46.8, 0.1);
  EXPECT_DOUBLE_EQ(body.material.youngs_modulus_mpa, 0.5032);
  EXPECT_DOUBLE_EQ(body.material.poisson_ratio, 0.49);
  EXPECT_DOUBLE_EQ(body.marker_pitch_mm, dome.pitch_mm);
  // The markers are the calibration's reference pixels triangulated, each 0.5 mm under the
  // surface up to the fit's residual.
  const std::vector<Triangulation> reference = VendorStereo(config).TriangulateReference();
  ASSERT_EQ(body.marker_positions_mm.size(), 400u);
  const Eigen::Vector3d sphere_center = body.base_center_mm + Eigen::Vector3d(0, 0, body.sphere_center_z_mm());
  for (size_t k = 0; k < reference.size(); ++k) {
    EXPECT_EQ(body.marker_positions_mm[k], reference[k].point);
    EXPECT_NEAR(body.sphere_radius_mm - (body.marker_positions_mm[k] - sphere_center).norm(), 0.5,
                dome.max_mm + 1e-9);
  }
  EXPECT_THAT(DescribeVendorGel(body, {}), HasSubstr("10.047 mm thick on the axis"));
}

TEST(VendorGel, AssumptionsMoveTheSurfaceAndTheBase) {
  const SensorConfig config = testing::FixtureVendorSensor();
  const fem::BodyModelOptions nominal = VendorBodyModelOptions(config);
  const fem::BodyModelOptions deeper = VendorBodyModelOptions(config, {.marker_depth_mm = 1.0});
  EXPECT_NEAR(deeper.thickness_mm - nominal.thickness_mm, 0.5, 1e-12);
  EXPECT_NEAR(deeper.sphere_radius_mm - nominal.sphere_radius_mm, 0.5, 1e-12);
  const fem::BodyModelOptions thicker = VendorBodyModelOptions(config, {.base_offset_mm = -1.0, .base_diameter_mm = 40.0});
  EXPECT_NEAR(thicker.thickness_mm - nominal.thickness_mm, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(thicker.base_center_mm.z(), -1.0);
  EXPECT_DOUBLE_EQ(thicker.base_diameter_mm, 40.0);
  EXPECT_EQ(thicker.marker_positions_mm, nominal.marker_positions_mm);
  EXPECT_DOUBLE_EQ(VendorBodyModelOptions(config, {.refinement = 0.5}).refinement, 0.5);
}

TEST(VendorGel, RefusesBadAssumptionsAndSensorsWithoutTheVendorModel) {
  const SensorConfig config = testing::FixtureVendorSensor();
  EXPECT_THAT(Refusal(config, {.marker_depth_mm = 0.0}), HasSubstr("VendorGelOptions.marker_depth_mm"));
  EXPECT_THAT(Refusal(config, {.base_diameter_mm = -1.0}), HasSubstr("VendorGelOptions.base_diameter_mm"));
  EXPECT_THAT(Refusal(config, {.refinement = 5.0}), HasSubstr("VendorGelOptions.refinement"));
  // A marker depth the fit's residual exceeds puts markers outside the gel.
  EXPECT_THAT(Refusal(config, {.marker_depth_mm = 0.05}), HasSubstr("is not inside the body"));
  // A base above the markers' sphere's top.
  EXPECT_THAT(Refusal(config, {.base_offset_mm = 12.0}), HasSubstr("does not reach the base"));
  EXPECT_THAT(Refusal(SensorConfig{}, {}), HasSubstr("vendor"));
}

TEST(VendorGel, CoarseComplianceBuildsWithTheMarkersWhereTheyAre) {
  const SensorConfig config = testing::FixtureVendorSensor();
  const fem::BodyModelOptions body = VendorBodyModelOptions(config, {.refinement = 0.25});
  const fem::ComplianceModel model = fem::CalcComplianceModel(body);
  ASSERT_EQ(model.h.rows(), 1200);
  EXPECT_EQ(model.marker_positions, body.marker_positions_mm);
  // Pressing a marker's patch down moves it down.
  for (int k = 0; k < 400; k += 57) EXPECT_GT(model.h(800 + k, 800 + k), 0.0);
}

}  // namespace
}  // namespace tac3d
