#include "tac3d/optics/optical_layout.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

// A hand-made periscope per half: an inner mirror at 45 deg above the camera sends the
// view sideways, an outer one at 60 deg sends it up and inwards to the gel.
OpticalLayout Periscope() {
  OpticalLayout layout;
  layout.intrinsics = CameraIntrinsics::FromFieldOfView(640, 480, 48.0);
  layout.intrinsics.distortion = {-0.05, 0.01, 0.0, 0.0, 0.0};
  layout.sensor_from_cam.translation() = Eigen::Vector3d(0, 0, -40);
  for (ImageHalf half : kImageHalves) {
    const double s = half == ImageHalf::kLeft ? -1.0 : 1.0;
    MirrorPair& pair = layout.mirrors[static_cast<int>(half)];
    // Inner: through (0, 0, -30), facing down and outwards.
    pair.inner.center = {s * 4.0, 0, -26};
    pair.inner.u_axis = Eigen::Vector3d(s * 1, 0, 1).normalized();
    pair.inner.v_axis = Eigen::Vector3d::UnitY() * s;
    pair.inner.half_u = 5.6;  // ends just short of the apex on the axis
    pair.inner.half_v = 20.0;
    if (pair.inner.normal().z() > 0) pair.inner.v_axis *= -1;
    // Outer: far to the side, tilted to send the beam up and inwards.
    const double tilt = DegToRad(22.5 + 45.0);
    pair.outer.center = {s * 30.0, 0, -30};
    pair.outer.u_axis = Eigen::Vector3d(s * std::cos(tilt), 0, std::sin(tilt));
    pair.outer.v_axis = Eigen::Vector3d::UnitY();
    pair.outer.half_u = 15.0;
    pair.outer.half_v = 30.0;
    if (pair.outer.normal().x() * s > 0) pair.outer.v_axis *= -1;
  }
  return layout;
}

TEST(OpticalLayout, VirtualCameraIsARigidMotionOfTheCamera) {
  const OpticalLayout layout = Periscope();
  for (ImageHalf half : kImageHalves) {
    const Rigid3 v = layout.SensorFromVirtualCamera(half);
    EXPECT_NEAR(v.linear().determinant(), 1.0, 1e-12);
    const MirrorPair& p = layout.pair(half);
    const Eigen::Vector3d o = layout.sensor_from_cam.translation();
    EXPECT_THAT(v.translation(), EigenNear(p.outer.plane().Reflect(p.inner.plane().Reflect(o)), 1e-12));
  }
}

TEST(OpticalLayout, TracedRaysLeaveTheOuterMirrorAlongTheVirtualCamerasRay) {
  OpticalLayout layout = Periscope();
  layout.layers.has_gel = false;
  int traced = 0;
  for (double u = 5; u < 640; u += 30) {
    for (double v = 5; v < 480; v += 30) {
      const TracedRay r = TracePixel(layout, {u, v});
      if (!r.ok()) continue;
      ++traced;
      EXPECT_EQ(r.half, u < layout.intrinsics.cx ? ImageHalf::kLeft : ImageHalf::kRight);
      const Rigid3 vcam = layout.SensorFromVirtualCamera(r.half);
      const Eigen::Vector3d expected = vcam.linear() * layout.intrinsics.Unproject({u, v});
      EXPECT_THAT(r.in_air.direction, EigenNear(expected, 1e-12));
      // The outgoing ray lies on the line through the virtual camera's centre.
      const Eigen::Vector3d to_center = vcam.translation() - r.in_air.origin;
      EXPECT_LT((to_center - to_center.dot(expected) * expected).norm(), 1e-9);
    }
  }
  EXPECT_GT(traced, 100);
}

TEST(OpticalLayout, ProjectPointInvertsTheRefractedTrace) {
  const OpticalLayout layout = Periscope();
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> u(0, 639), v(0, 479), depth(0.5, 12.0);
  int checked = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    const TracedRay r = TracePixel(layout, pixel);
    if (!r.ok()) continue;
    ++checked;
    EXPECT_NEAR(r.in_silicone.origin.z(), 0.0, 1e-12);
    const Eigen::Vector3d p = r.in_silicone.At(depth(rng));
    const auto projected = ProjectPoint(layout, r.half, p);
    ASSERT_TRUE(projected.has_value());
    EXPECT_THAT(*projected, EigenNear(pixel, 1e-7));
  }
  EXPECT_GT(checked, 500);
}

TEST(OpticalLayout, RefractionBendsTowardsTheNormal) {
  const OpticalLayout layout = Periscope();
  const TracedRay r = TracePixel(layout, {200, 240});
  ASSERT_TRUE(r.ok());
  const double sin_air = r.in_air.direction.head<2>().norm();
  const double sin_silicone = r.in_silicone.direction.head<2>().norm();
  EXPECT_NEAR(sin_air, layout.layers.silicone_index * sin_silicone, 1e-12);
}

TEST(OpticalLayout, RayAwayFromTheMirrorsIsReported) {
  const OpticalLayout layout = Periscope();
  const TracedRay r = TraceCameraRay(layout, Ray{{0, 0, -40}, {0, 0, -1}});
  EXPECT_EQ(r.status, TraceStatus::kMissedMirrors);
}

}  // namespace
}  // namespace tac3d
