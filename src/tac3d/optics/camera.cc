#include "tac3d/optics/camera.h"

#include <cmath>

#include <Eigen/LU>

#include "tac3d/geometry/geometry.h"
#include "tac3d/util/error.h"

namespace tac3d {

CameraIntrinsics CameraIntrinsics::FromFieldOfView(int width, int height,
                                                   double horizontal_fov_deg) {
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = 0.5 * width / std::tan(DegToRad(0.5 * horizontal_fov_deg));
  c.fy = c.fx;
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  return c;
}

Eigen::Matrix3d CameraIntrinsics::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector2d CameraIntrinsics::Distort(const Eigen::Vector2d& n) const {
  const auto [k1, k2, p1, p2, k3] = distortion;
  const double x = n.x(), y = n.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

Eigen::Vector2d CameraIntrinsics::Undistort(const Eigen::Vector2d& distorted) const {
  const auto [k1, k2, p1, p2, k3] = distortion;
  if (k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0) return distorted;
  Eigen::Vector2d n = distorted;
  for (int it = 0; it < 20; ++it) {
    const double x = n.x(), y = n.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);  // d radial / d r2
    Eigen::Matrix2d j;
    j(0, 0) = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x;
    j(0, 1) = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
    j(1, 0) = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
    j(1, 1) = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
    const Eigen::Vector2d step = j.inverse() * (Distort(n) - distorted);
    n -= step;
    if (step.squaredNorm() < 1e-30) break;
  }
  return n;
}

Eigen::Vector2d CameraIntrinsics::Project(const Eigen::Vector3d& p_in_cam) const {
  TAC3D_DEMAND(p_in_cam.z() > 0.0);
  const Eigen::Vector2d d = Distort(p_in_cam.head<2>() / p_in_cam.z());
  return {fx * d.x() + cx, fy * d.y() + cy};
}

Eigen::Vector3d CameraIntrinsics::Unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d n = Undistort({(pixel.x() - cx) / fx, (pixel.y() - cy) / fy});
  return Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
}

}  // namespace tac3d
