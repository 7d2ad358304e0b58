#include "tac3d/vendor_formats/vendor_stereo.h"

#include <fmt/format.h>

#include "tac3d/geometry/geometry.h"
#include "tac3d/util/error.h"

namespace tac3d {

VendorStereo::VendorStereo(const SensorConfig& config, const VendorStereoOptions& options)
    : intrinsics_(config.camera.intrinsics), options_(options) {
  if (!config.vendor_camera) {
    throw Error("the sensor config has no vendor camera model (camera_model): import the sensor's "
                "calibration folder with `tac3d import-vendor` first");
  }
  model_ = *config.vendor_camera;
  if (!options_.undistort) intrinsics_.distortion = {};
}

std::optional<Ray> VendorStereo::PixelRay(ImageHalf view, const Eigen::Vector2d& pixel) const {
  const Rigid3& sensor_from_view = model_.sensor_from_view[static_cast<int>(view)];
  const Ray straight{sensor_from_view.translation(), sensor_from_view.linear() * intrinsics_.Unproject(pixel)};
  const RefractionPlaneConfig& r = model_.refraction;
  const Plane plane = Plane::FromPointNormal({0, 0, r.height_mm}, r.Normal());
  const std::optional<double> t = IntersectRayPlane(straight, plane);
  if (!t) return std::nullopt;
  if (!options_.refract) return straight;
  const std::optional<Eigen::Vector3d> bent = RefractDirection(straight.direction, plane.normal, 1.0, r.index_ratio);
  if (!bent) return std::nullopt;
  return Ray{straight.At(*t), bent->normalized()};
}

std::optional<Eigen::Vector2d> VendorStereo::Project(ImageHalf view, const Eigen::Vector3d& p_in_sensor) const {
  const Rigid3& sensor_from_view = model_.sensor_from_view[static_cast<int>(view)];
  const Eigen::Vector3d centre = sensor_from_view.translation();
  Eigen::Vector3d crossing = p_in_sensor;  // where the ray meets the plane (or the point itself)
  if (options_.refract) {
    const RefractionPlaneConfig& r = model_.refraction;
    const Eigen::Vector3d normal = r.Normal();
    const Eigen::Vector3d origin(0, 0, r.height_mm);
    const double a = normal.dot(origin - centre);       // camera to plane, along the normal
    const double b = normal.dot(p_in_sensor - origin);  // plane to point
    if (!(a > 0) || !(b > 0)) return std::nullopt;
    // In the plane: the camera's foot, then the direction to the point's foot, `length` away.
    const Eigen::Vector3d camera_foot = centre + a * normal;
    const Eigen::Vector3d across = (p_in_sensor - b * normal) - camera_foot;
    const double length = across.norm();
    if (length > 1e-12) {
      // Snell: sin(incidence) = index_ratio * sin(refraction) rises monotonically with x in [0, length].
      auto mismatch = [&](double x) {
        return x / std::hypot(x, a) - r.index_ratio * (length - x) / std::hypot(length - x, b);
      };
      double lo = 0.0, hi = length;
      while (hi - lo > 1e-12) {
        const double mid = 0.5 * (lo + hi);
        (mismatch(mid) < 0 ? lo : hi) = mid;
      }
      crossing = camera_foot + (0.5 * (lo + hi) / length) * across;
    } else {
      crossing = camera_foot;
    }
  }
  const Eigen::Vector3d in_view = sensor_from_view.inverse() * crossing;
  if (!(in_view.z() > 0)) return std::nullopt;
  return intrinsics_.Project(in_view);
}

Triangulation VendorStereo::Triangulate(const Eigen::Vector2d& pixel_left,
                                        const Eigen::Vector2d& pixel_right) const {
  const std::optional<Ray> left = PixelRay(ImageHalf::kLeft, pixel_left);
  const std::optional<Ray> right = PixelRay(ImageHalf::kRight, pixel_right);
  if (!left || !right) return {};
  return TriangulateRays(*left, *right);
}

std::vector<Triangulation> VendorStereo::TriangulateReference() const {
  const auto& pixels = model_.reference_pixels;
  std::vector<Triangulation> points;
  points.reserve(pixels[0].size());
  for (size_t i = 0; i < pixels[0].size(); ++i) points.push_back(Triangulate(pixels[0][i], pixels[1][i]));
  return points;
}

}  // namespace tac3d

namespace tac3d {

VendorMarkerTriangulator::VendorMarkerTriangulator(const SensorConfig& config, double max_ray_gap_mm)
    : StereoTriangulator(config.markers.rows * config.markers.cols),
      stereo_(config),
      model_(*config.vendor_camera),
      width_(config.camera.intrinsics.width),
      height_(config.camera.intrinsics.height),
      max_ray_gap_mm_(max_ray_gap_mm) {
  if (!(max_ray_gap_mm > 0)) {
    throw Error(fmt::format("vendor triangulation: max_ray_gap_mm = {} must be > 0", max_ray_gap_mm));
  }
}

std::optional<Eigen::Vector3d> VendorMarkerTriangulator::TriangulateMarker(const Eigen::Vector2d& left,
                                                                           const Eigen::Vector2d& right) const {
  const Triangulation t =
      stereo_.Triangulate(model_.FlipPixel(left, width_, height_), model_.FlipPixel(right, width_, height_));
  if (!t.valid || t.residual > max_ray_gap_mm_) return std::nullopt;
  return t.point;
}

}  // namespace tac3d
