#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/stereo/marker_field.h"
#include "tac3d/stereo/stereo_rig.h"

namespace tac3d {

/// Which parts of the vendor's camera model to apply; both on is the model. Turning one off
/// measures what it is worth (docs/real-sensors.md).
struct VendorStereoOptions {
  bool undistort = true;  ///< OpenCV's distortion model on the pixels
  bool refract = true;    ///< the refraction at the plane z = h0
};

/// A real Tac3D's stereo as its vendor models it (SensorConfig::vendor_camera): each view a
/// pinhole camera with the one physical camera's intrinsics and distortion, at its own pose in
/// the sensor frame; a pixel's ray goes straight to the refracting plane, bends there once by
/// Snell's law (air to gel, index ratio n21), and a marker is the midpoint of the closest
/// points of its two views' rays.
class VendorStereo {
 public:
  /// @throws Error if the config has no vendor camera model (`tac3d import-vendor` makes one).
  explicit VendorStereo(const SensorConfig& config, const VendorStereoOptions& options = {});

  /// The ray of a pixel of one view in the sensor frame, past the refracting plane (or the
  /// straight ray, without refraction); nullopt if it never reaches the plane going forward.
  std::optional<Ray> PixelRay(ImageHalf view, const Eigen::Vector2d& pixel) const;
  /// The pixel of a point of the sensor frame in one view: the inverse of PixelRay. With the
  /// refraction, the point where the ray crosses the plane is solved for in the plane of
  /// incidence (Snell's law, bisection to 1e-12 mm); nullopt for a point on the camera's side of
  /// the plane or behind the view.
  std::optional<Eigen::Vector2d> Project(ImageHalf view, const Eigen::Vector3d& p_in_sensor) const;
  /// One marker from its pixels in both views; `residual` is the gap between the rays (mm).
  Triangulation Triangulate(const Eigen::Vector2d& pixel_left, const Eigen::Vector2d& pixel_right) const;
  /// Every marker's reference position from its reference pixels, row-major.
  std::vector<Triangulation> TriangulateReference() const;

 private:
  CameraIntrinsics intrinsics_;
  VendorCameraModelConfig model_;
  VendorStereoOptions options_;
};

/// The measurement chain's triangulation for a vendor-calibrated sensor (Pipeline): the tracked
/// pixels, in the camera's image as delivered, flipped as the vendor does
/// (VendorCameraModelConfig::FlipPixel) and triangulated by VendorStereo.
class VendorMarkerTriangulator : public StereoTriangulator {
 public:
  /// @param max_ray_gap_mm a pair whose refracted rays miss each other by more is a mismatch.
  /// @throws Error as VendorStereo does, or if max_ray_gap_mm is not > 0.
  VendorMarkerTriangulator(const SensorConfig& config, double max_ray_gap_mm);

  const VendorStereo& stereo() const { return stereo_; }

 private:
  std::optional<Eigen::Vector3d> TriangulateMarker(const Eigen::Vector2d& left,
                                                   const Eigen::Vector2d& right) const override;

  VendorStereo stereo_;
  VendorCameraModelConfig model_;
  int width_, height_;
  double max_ray_gap_mm_;
};

}  // namespace tac3d
