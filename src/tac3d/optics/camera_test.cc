#include "tac3d/optics/camera.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "tac3d/geometry/geometry.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

CameraIntrinsics DistortedCamera() {
  CameraIntrinsics c = CameraIntrinsics::FromFieldOfView(640, 480, 48.0);
  c.distortion = {-0.21, 0.09, 0.0012, -0.0008, -0.015};
  return c;
}

TEST(CameraIntrinsics, FieldOfViewReachesTheImageEdge) {
  const CameraIntrinsics c = CameraIntrinsics::FromFieldOfView(640, 480, 48.0);
  // The left edge of pixel 0 is at u = -0.5.
  const Eigen::Vector3d d = c.Unproject({-0.5, c.cy});
  EXPECT_NEAR(RadToDeg(std::atan2(-d.x(), d.z())), 24.0, 1e-12);
}

TEST(CameraIntrinsics, ProjectUnprojectRoundTripWithDistortion) {
  const CameraIntrinsics c = DistortedCamera();
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> u(0, 639), v(0, 479);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    const Eigen::Vector3d d = c.Unproject(pixel);
    EXPECT_NEAR(d.norm(), 1.0, 1e-14);
    EXPECT_THAT(c.Project(3.7 * d), EigenNear(pixel, 1e-9));
  }
}

TEST(CameraIntrinsics, MatchesOpenCvDistortionFormula) {
  const CameraIntrinsics c = DistortedCamera();
  const auto [k1, k2, p1, p2, k3] = c.distortion;
  const double x = 0.3, y = -0.2, r2 = x * x + y * y;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const Eigen::Vector2d expected(x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                                 y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y);
  EXPECT_THAT(c.Distort({x, y}), EigenNear(expected, 1e-15));
}

}  // namespace
}  // namespace tac3d
