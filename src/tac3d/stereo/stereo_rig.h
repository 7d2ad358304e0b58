#pragma once

#include <array>
#include <limits>
#include <optional>

#include <Eigen/Core>

#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// The virtual stereo pair as calibrated (SensorConfig::virtual_cameras): two cameras in
/// the sensor frame, each with its own intrinsics in full-image pixel coordinates, and the
/// flat layers (glass, silicone) between them and the markers.
struct StereoRig {
  std::array<Rigid3, 2> sensor_from_vcam;        ///< indexed by ImageHalf
  std::array<CameraIntrinsics, 2> intrinsics;
  FlatLayers layers;

  /// @throws Error if the config has no virtual cameras (run design or calibrate first).
  static StereoRig FromSensorConfig(const SensorConfig& config, bool with_gel = true);

  /// The straight (air) ray of a pixel of one virtual camera, sensor frame.
  Ray PixelRay(ImageHalf half, const Eigen::Vector2d& pixel) const;
  /// Exact image of a point through the layers (see ProjectThroughLayers).
  std::optional<Eigen::Vector2d> Project(ImageHalf half, const Eigen::Vector3d& p_in_sensor) const;
};

/// A triangulated point and how well the two views agree on it: for the midpoint method
/// the gap between the two rays (mm), for the refracted one the reprojection error (px).
struct Triangulation {
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double residual = std::numeric_limits<double>::quiet_NaN();
  bool valid = false;
};

/// The midpoint of the common perpendicular of two rays, with their gap (mm) as the residual.
/// Invalid for (nearly) parallel rays or a closest point behind either ray's origin.
Triangulation TriangulateRays(const Ray& a, const Ray& b);

/// The midpoint of the common perpendicular of the two pixels' straight rays: stereo as if
/// there were no glass or silicone. Invalid for (nearly) parallel rays or a point behind a
/// camera.
Triangulation TriangulateMidpoint(const StereoRig& rig, const Eigen::Vector2d& pixel_left,
                                  const Eigen::Vector2d& pixel_right);

/// The point whose exact refracted images (ProjectThroughLayers) best match the two pixels
/// (Gauss-Newton on the reprojection error from `initial`); slower, for reference.
Triangulation TriangulateRefracted(const StereoRig& rig, const Eigen::Vector2d& pixel_left,
                                   const Eigen::Vector2d& pixel_right,
                                   const Eigen::Vector3d& initial);

}  // namespace tac3d
