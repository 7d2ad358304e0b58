#include "tac3d/twin/vendor_optics.h"

#include "tac3d/util/error.h"

namespace tac3d {

VendorOptics::VendorOptics(const SensorConfig& config)
    : intrinsics_(config.camera.intrinsics),
      model_(config.vendor_camera ? *config.vendor_camera : VendorCameraModelConfig{}),
      stereo_(config),
      columns_(model_.ViewColumns(intrinsics_.width, intrinsics_.height)) {}

std::optional<HalfRay> VendorOptics::Trace(const Eigen::Vector2d& pixel) const {
  for (const ImageHalf half : kImageHalves) {
    const auto [first, last] = columns_[static_cast<int>(half)];
    // Pixel u spans [u - 0.5, u + 0.5]: the cut's point goes to the view left of it.
    if (pixel.x() < first - 0.5 || pixel.x() > last - 0.5 || (first > 0 && pixel.x() == first - 0.5)) continue;
    const std::optional<Ray> ray =
        stereo_.PixelRay(half, model_.FlipPixel(pixel, intrinsics_.width, intrinsics_.height));
    if (!ray) return std::nullopt;
    return HalfRay{half, *ray};
  }
  return std::nullopt;
}

std::optional<Eigen::Vector2d> VendorOptics::Project(ImageHalf half, const Eigen::Vector3d& p_in_sensor) const {
  const std::optional<Eigen::Vector2d> pixel = stereo_.Project(half, p_in_sensor);
  if (!pixel) return std::nullopt;
  return model_.FlipPixel(*pixel, intrinsics_.width, intrinsics_.height);
}

}  // namespace tac3d
