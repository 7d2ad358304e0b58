#include "tac3d/stereo/stereo_rig.h"

#include <Eigen/Cholesky>

#include "tac3d/util/error.h"

namespace tac3d {

StereoRig StereoRig::FromSensorConfig(const SensorConfig& config, bool with_gel) {
  if (config.virtual_cameras.size() != 2) {
    throw Error("sensor config has no virtual cameras: run `tac3d design` or `tac3d calibrate`");
  }
  StereoRig rig;
  for (const VirtualCameraConfig& v : config.virtual_cameras) {
    const int i = static_cast<int>(v.half);
    rig.sensor_from_vcam[i] = v.sensor_from_vcam;
    rig.intrinsics[i] = v.intrinsics;
  }
  rig.layers = config.MakeFlatLayers(with_gel);
  return rig;
}

Ray StereoRig::PixelRay(ImageHalf half, const Eigen::Vector2d& pixel) const {
  const int i = static_cast<int>(half);
  return {sensor_from_vcam[i].translation(),
          sensor_from_vcam[i].linear() * intrinsics[i].Unproject(pixel)};
}

std::optional<Eigen::Vector2d> StereoRig::Project(ImageHalf half,
                                                  const Eigen::Vector3d& p_in_sensor) const {
  const int i = static_cast<int>(half);
  return ProjectThroughLayers(sensor_from_vcam[i], intrinsics[i], layers, p_in_sensor);
}

Triangulation TriangulateMidpoint(const StereoRig& rig, const Eigen::Vector2d& pixel_left,
                                  const Eigen::Vector2d& pixel_right) {
  return TriangulateRays(rig.PixelRay(ImageHalf::kLeft, pixel_left),
                         rig.PixelRay(ImageHalf::kRight, pixel_right));
}

Triangulation TriangulateRays(const Ray& a, const Ray& b) {
  // Closest points a.At(s), b.At(t): solve the 2x2 normal equations.
  const Eigen::Vector3d w = a.origin - b.origin;
  const double ab = a.direction.dot(b.direction);
  const double denom = 1.0 - ab * ab;
  Triangulation out;
  if (denom < 1e-10) return out;
  const double da = a.direction.dot(w), db = b.direction.dot(w);
  const double s = (ab * db - da) / denom;
  const double t = (db - ab * da) / denom;
  if (s <= 0 || t <= 0) return out;
  const Eigen::Vector3d pa = a.At(s), pb = b.At(t);
  out.point = 0.5 * (pa + pb);
  out.residual = (pa - pb).norm();
  out.valid = true;
  return out;
}

Triangulation TriangulateRefracted(const StereoRig& rig, const Eigen::Vector2d& pixel_left,
                                   const Eigen::Vector2d& pixel_right,
                                   const Eigen::Vector3d& initial) {
  const std::array<Eigen::Vector2d, 2> observed = {pixel_left, pixel_right};
  auto residual = [&](const Eigen::Vector3d& p, Eigen::Vector4d& r) {
    for (ImageHalf half : kImageHalves) {
      const auto uv = rig.Project(half, p);
      if (!uv) return false;
      r.segment<2>(2 * static_cast<int>(half)) = *uv - observed[static_cast<int>(half)];
    }
    return true;
  };
  Triangulation out;
  Eigen::Vector3d p = initial;
  Eigen::Vector4d r;
  if (!residual(p, r)) return out;
  for (int it = 0; it < 20; ++it) {
    Eigen::Matrix<double, 4, 3> jacobian;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d q = p;
      q(k) += 1e-6;
      Eigen::Vector4d rq;
      if (!residual(q, rq)) return out;
      jacobian.col(k) = (rq - r) / 1e-6;
    }
    const Eigen::Vector3d step = (jacobian.transpose() * jacobian).ldlt().solve(-jacobian.transpose() * r);
    p += step;
    if (!residual(p, r)) return out;
    if (step.norm() < 1e-10) break;
  }
  out.point = p;
  out.residual = r.norm();
  out.valid = true;
  return out;
}

}  // namespace tac3d
