#include "tac3d/vendor/vendor_stereo.h"

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
