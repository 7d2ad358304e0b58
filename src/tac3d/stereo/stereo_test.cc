#include <random>

#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/stereo/refraction_compensation.h"
#include "tac3d/stereo/stereo_rig.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::DefaultSensor;

std::vector<Eigen::Vector3d> RandomMarkerVolumePoints(int count) {
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> xy(-12.0, 12.0), dz(-2.5, 0.3);
  const auto reference = DefaultSensor().MarkerPositions();
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d p(xy(rng), xy(rng), 0.0);
    const SensorConfig& sensor = DefaultSensor();
    const double r = sensor.elastic_body.outer_radius_mm - sensor.markers.depth_mm;
    p.z() = sensor.SphereCenter().z() + std::sqrt(r * r - p.head<2>().squaredNorm()) + dz(rng);
    points.push_back(p);
  }
  return points;
}

TEST(StereoRig, MidpointRecoversPointsSeenThroughAir) {
  const StereoRig rig = StereoRig::FromSensorConfig(DefaultSensor(), /*with_gel=*/false);
  for (const auto& p : RandomMarkerVolumePoints(200)) {
    const Triangulation t = TriangulateMidpoint(rig, *rig.Project(ImageHalf::kLeft, p),
                                                *rig.Project(ImageHalf::kRight, p));
    ASSERT_TRUE(t.valid);
    EXPECT_THAT(t.point, EigenNear(p, 1e-9));
    EXPECT_LT(t.residual, 1e-9);
  }
}

TEST(StereoRig, RefractedTriangulationRecoversPointsInTheSilicone) {
  const StereoRig rig = StereoRig::FromSensorConfig(DefaultSensor(), /*with_gel=*/true);
  double uncorrected_worst = 0.0;
  for (const auto& p : RandomMarkerVolumePoints(100)) {
    const Eigen::Vector2d l = *rig.Project(ImageHalf::kLeft, p), r = *rig.Project(ImageHalf::kRight, p);
    const Triangulation air = TriangulateMidpoint(rig, l, r);
    ASSERT_TRUE(air.valid);
    uncorrected_worst = std::max(uncorrected_worst, (air.point - p).norm());
    const Triangulation exact = TriangulateRefracted(rig, l, r, air.point);
    ASSERT_TRUE(exact.valid);
    EXPECT_THAT(exact.point, EigenNear(p, 1e-6));
    EXPECT_LT(exact.residual, 1e-6);
  }
  // Refraction matters: stereo as if through air is millimetres off.
  EXPECT_GT(uncorrected_worst, 1.0);
}

TEST(RefractionCompensation, PolynomialCorrectsTheRefractionShift) {
  const StereoRig rig = StereoRig::FromSensorConfig(DefaultSensor(), true);
  const RefractionCompensation compensation = RefractionCompensation::Fit(rig, DefaultSensor());
  const auto& s = compensation.summary();
  EXPECT_GT(s.max_deviation_mm, 1.0);
  EXPECT_LT(s.validation_rms_mm, 0.002);
  EXPECT_LT(s.validation_max_mm, 0.01);
  std::printf("refraction shift up to %.3f mm; polynomial (%d terms) leaves rms %.5f, max %.5f mm\n",
              s.max_deviation_mm, s.terms, s.validation_rms_mm, s.validation_max_mm);
  // Independent check on points of this test's own.
  for (const auto& p : RandomMarkerVolumePoints(200)) {
    const Triangulation air = TriangulateMidpoint(rig, *rig.Project(ImageHalf::kLeft, p),
                                                  *rig.Project(ImageHalf::kRight, p));
    EXPECT_LT((compensation.Correct(air.point) - p).norm(), 0.01);
  }
}

TEST(StereoRig, NeedsVirtualCameras) {
  EXPECT_THROW(StereoRig::FromSensorConfig(SensorConfig{}), Error);
}

TEST(RefractionCompensationOptions, AreValidated) {
  RefractionCompensationOptions o;
  o.degree = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.samples_per_axis = 3;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.below_mm = -1;
  EXPECT_THROW(o.Validate(), Error);
}

}  // namespace
}  // namespace tac3d
