#pragma once

#include <array>
#include <utility>

#include "tac3d/twin/ray_field.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

namespace tac3d {

/// A vendor-calibrated sensor's optics for the twin (SensorConfig::vendor_camera): both views in
/// the one camera image, each owning the columns VendorCameraModelConfig::ViewColumns gives it
/// (a pixel point on the cut belongs to the left one of the two), the pixel flipped as the vendor
/// does, then the view's pinhole, distortion and refraction (VendorStereo::PixelRay, Project).
class VendorOptics : public PixelOptics {
 public:
  /// @throws Error if the config has no vendor camera model or its views overlap in u.
  explicit VendorOptics(const SensorConfig& config);

  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  std::optional<HalfRay> Trace(const Eigen::Vector2d& pixel) const override;
  std::optional<Eigen::Vector2d> Project(ImageHalf half, const Eigen::Vector3d& p_in_sensor) const override;

 private:
  CameraIntrinsics intrinsics_;
  VendorCameraModelConfig model_;
  VendorStereo stereo_;
  std::array<std::pair<int, int>, 2> columns_;
};

}  // namespace tac3d
