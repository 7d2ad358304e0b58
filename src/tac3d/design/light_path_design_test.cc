#include "tac3d/design/light_path_design.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

class PrototypeDesign : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { design_ = new LightPathDesign(DesignLightPath({})); }
  static void TearDownTestSuite() { delete design_; }
  static const LightPathRoot& root() { return design_->roots.at(*design_->chosen); }
  static LightPathDesign* design_;
};
LightPathDesign* PrototypeDesign::design_ = nullptr;

TEST_F(PrototypeDesign, HasExactlyOneValidLayoutAmongSeveralRoots) {
  ASSERT_TRUE(design_->chosen.has_value());
  EXPECT_EQ(design_->summary.valid_roots, 1);
  EXPECT_GT(design_->summary.distinct_roots, 1);
  for (const auto& r : design_->roots) {
    if (!r.valid()) {
      EXPECT_FALSE(r.rejections.front().empty());
    }
  }
}

TEST_F(PrototypeDesign, EveryEquationIsSolved) {
  for (int i = 0; i < 4; ++i) EXPECT_LT(std::abs(root().residuals(i)), 1e-9) << "equation " << i;
}

TEST_F(PrototypeDesign, ParallaxIsNinetyDegrees) { EXPECT_NEAR(root().parallax_deg, 90.0, 1e-6); }

TEST_F(PrototypeDesign, LayoutIsBetweenCameraAndFingertip) {
  const LightPathRoot& r = root();
  EXPECT_NEAR(r.b2.x(), 0.0, 1e-12);  // B2 on the axis
  for (const Eigen::Vector2d& p : {r.a1, r.b1, r.a2, r.b2}) {
    EXPECT_GT(p.y(), -40.0);
    EXPECT_LT(p.y(), 0.0);
    EXPECT_LE(p.x(), 0.0);
  }
}

// Follows light from a fingertip end through the designed 3D mirrors of one half.
struct Arrival {
  double miss_mm;        // distance of the final ray from the camera centre
  double off_axis_deg;   // angle between the final ray and the optical axis
};
Arrival TraceToCamera(const SensorConfig& config, ImageHalf half, const Eigen::Vector3d& start,
                      const Eigen::Vector3d& towards) {
  const OpticalLayout layout = config.MakeOpticalLayout(false);
  const MirrorPair& pair = layout.pair(half);
  Ray ray{start, (towards - start).normalized()};
  for (const Rectangle3* mirror : {&pair.outer, &pair.inner}) {
    const auto t = IntersectRayPlane(ray, mirror->plane(), 1e-9);
    EXPECT_TRUE(t.has_value());
    EXPECT_TRUE(mirror->Contains(ray.At(*t), 1e-9)) << "misses the mirror rectangle";
    EXPECT_LT(ray.direction.dot(mirror->normal()), 0.0) << "hits the back of a mirror";
    ray = Ray{ray.At(*t), ReflectDirection(ray.direction, mirror->normal())};
  }
  const Eigen::Vector3d o = config.camera.sensor_from_cam.translation();
  const Eigen::Vector3d to_o = o - ray.origin;
  return {(to_o - to_o.dot(ray.direction) * ray.direction).norm(),
          RadToDeg(std::atan2(ray.direction.head<2>().norm(), -ray.direction.z()))};
}

TEST_F(PrototypeDesign, RaysFromTheFingertipEndsReachTheCameraAtZeroAndHalfTheFieldOfView) {
  const LightPathRoot& r = root();
  const SensorConfig& config = *design_->config;
  for (ImageHalf half : kImageHalves) {
    const double s = half == ImageHalf::kLeft ? 1.0 : -1.0;  // the right half is mirrored
    auto p3 = [s](const Eigen::Vector2d& p) { return Eigen::Vector3d(s * p.x(), 0.0, p.y()); };
    const Arrival a = TraceToCamera(config, half, p3(r.a0), p3(r.a1));
    EXPECT_LT(a.miss_mm, 1e-6);
    EXPECT_NEAR(a.off_axis_deg, 24.0, 1e-6);
    const Arrival b = TraceToCamera(config, half, p3(r.b0), p3(r.b1));
    EXPECT_LT(b.miss_mm, 1e-6);
    EXPECT_NEAR(b.off_axis_deg, 0.0, 1e-6);
  }
}

TEST_F(PrototypeDesign, VirtualCamerasAreMirrorImagesLookingAtTheCentre) {
  const SensorConfig& config = *design_->config;
  ASSERT_EQ(config.virtual_cameras.size(), 2u);
  const Eigen::Vector3d left = config.virtual_cameras[0].sensor_from_vcam.translation();
  const Eigen::Vector3d right = config.virtual_cameras[1].sensor_from_vcam.translation();
  EXPECT_THAT(left, EigenNear(Eigen::Vector3d(root().virtual_camera.x(), 0, root().virtual_camera.y()), 1e-9));
  EXPECT_THAT(right, EigenNear(Eigen::Vector3d(-left.x(), left.y(), left.z()), 1e-9));
  EXPECT_NEAR(RadToDeg(std::acos(left.normalized().dot(right.normalized()))), 90.0, 1e-6);
  // The centre of the face is seen by both halves, each in its own columns.
  const OpticalLayout layout = config.MakeOpticalLayout(false);
  for (const VirtualCameraConfig& v : config.virtual_cameras) {
    const auto pixel = ProjectPoint(layout, v.half, Eigen::Vector3d::Zero());
    ASSERT_TRUE(pixel.has_value());
    EXPECT_GE(pixel->x(), v.column_begin - 0.5);
    EXPECT_LE(pixel->x(), v.column_end - 0.5);
    const TracedRay traced = TracePixel(layout, *pixel);
    ASSERT_TRUE(traced.ok()) << ToString(traced.status);
    EXPECT_EQ(traced.half, v.half);
  }
}

TEST_F(PrototypeDesign, WholeFingertipFaceIsInView) {
  const SensorConfig& config = *design_->config;
  const OpticalLayout layout = config.MakeOpticalLayout(false);
  for (ImageHalf half : kImageHalves) {
    for (double x : {-19.0, -10.0, 0.0, 10.0, 19.0}) {
      for (double y : {-12.7, 0.0, 12.7}) {
        const auto pixel = ProjectPoint(layout, half, {x, y, 0.0});
        ASSERT_TRUE(pixel.has_value());
        const TracedRay traced = TracePixel(layout, *pixel);
        EXPECT_TRUE(traced.ok()) << x << "," << y << ": " << ToString(traced.status);
      }
    }
  }
}

TEST(LightPathDesign, ImpossibleParametersAreReportedAsImpossible) {
  LightPathDesignOptions options;
  options.h_mm = 20.0;  // the camera too close for a 40 mm fingertip
  const LightPathDesign design = DesignLightPath(options);
  EXPECT_FALSE(design.chosen.has_value());
  EXPECT_FALSE(design.config.has_value());
  EXPECT_GT(design.summary.distinct_roots, 0);
  for (const auto& r : design.roots) EXPECT_FALSE(r.valid());
}

TEST(LightPathDesign, OtherSizesSolveToo) {
  LightPathDesignOptions options;
  options.h_mm = 60.0;
  options.l_mm = 60.0;
  const LightPathDesign design = DesignLightPath(options);
  ASSERT_TRUE(design.chosen.has_value());
  EXPECT_NEAR(design.roots[*design.chosen].parallax_deg, 90.0, 1e-6);
}

// The built-in sensor stores its design (sensor/default_sensor.cc) instead of solving for it at
// run time: the solver, run on the built-in sensor's design problem, must still give it.
TEST(DefaultSensorConfig, IsTheSolversDesignOfThePrototype) {
  const SensorConfig prototype;
  const LightPathDesign design = DesignLightPath(DesignOptionsOf(prototype), prototype);
  ASSERT_TRUE(design.config.has_value());
  const SensorConfig& solved = *design.config;
  SensorConfig stored = DefaultSensorConfig();
  constexpr double kLengthToleranceMm = 1e-9;
  constexpr double kDirectionTolerance = 1e-12;  // unit vectors and rotation entries
  ASSERT_EQ(stored.mirrors.size(), solved.mirrors.size());
  for (size_t i = 0; i < solved.mirrors.size(); ++i) {
    SCOPED_TRACE(solved.mirrors[i].name);
    const Rectangle3& a = stored.mirrors[i].surface;
    const Rectangle3& b = solved.mirrors[i].surface;
    EXPECT_THAT(a.center, EigenNear(b.center, kLengthToleranceMm));
    EXPECT_THAT(a.u_axis, EigenNear(b.u_axis, kDirectionTolerance));
    EXPECT_THAT(a.v_axis, EigenNear(b.v_axis, kDirectionTolerance));
    EXPECT_NEAR(a.half_u, b.half_u, kLengthToleranceMm);
    EXPECT_NEAR(a.half_v, b.half_v, kLengthToleranceMm);
    stored.mirrors[i].surface = b;  // equal within the tolerance: compared exactly below
  }
  ASSERT_EQ(stored.virtual_cameras.size(), solved.virtual_cameras.size());
  for (size_t i = 0; i < solved.virtual_cameras.size(); ++i) {
    SCOPED_TRACE(solved.virtual_cameras[i].name);
    const Rigid3& a = stored.virtual_cameras[i].sensor_from_vcam;
    const Rigid3& b = solved.virtual_cameras[i].sensor_from_vcam;
    EXPECT_THAT(Eigen::Vector3d(a.translation()),
                EigenNear(Eigen::Vector3d(b.translation()), kLengthToleranceMm));
    EXPECT_THAT(Eigen::Matrix3d(a.linear()),
                EigenNear(Eigen::Matrix3d(b.linear()), kDirectionTolerance));
    stored.virtual_cameras[i].sensor_from_vcam = b;
  }
  // The rest exactly: names, halves, intrinsics, column ranges and the undesigned sections.
  EXPECT_EQ(SensorConfigToYaml(stored), SensorConfigToYaml(solved));
}

TEST(LightPathDesign, OptionsAreValidated) {
  auto with = [](auto edit) {
    LightPathDesignOptions o;
    edit(o);
    return o;
  };
  EXPECT_THROW(with([](auto& o) { o.h_mm = 0; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.l_mm = -1; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.d_mm = 0; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.fov_deg = 180; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.starts_per_axis = 1; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.outer_mirror_margin = -0.1; }).Validate(), Error);
}

}  // namespace
}  // namespace tac3d
