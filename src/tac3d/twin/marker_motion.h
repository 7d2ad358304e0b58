#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// Known motions of the marker layer for measuring tracking and stereo against truth
/// (`tac3d eval markers`). They are kinematic fields, not contact mechanics: the
/// truth is the field itself.
enum class MarkerMotionKind {
  kShear,  ///< every marker moved by the same vector (mm)
  kDent,   ///< pressed by a sphere: markers under it pushed along -z to follow it
  kTwist,  ///< rotated about the sensor's axis by an angle that fades out with radius
};

struct MarkerMotion {
  MarkerMotionKind kind = MarkerMotionKind::kShear;
  std::string name;
  Eigen::Vector3d shear_mm = Eigen::Vector3d(0.5, 0, 0);
  double dent_depth_mm = 1.0;          ///< peak push at the centre
  double dent_sphere_radius_mm = 10.0; ///< the indenter's radius
  double twist_deg = 5.0;              ///< at the centre
  double twist_fade_radius_mm = 15.0;  ///< the angle falls off as exp(-(r / fade)^2)

  /// The moved positions of the given markers.
  std::vector<Eigen::Vector3d> Apply(const std::vector<Eigen::Vector3d>& markers) const;
};

/// The three fields `tac3d eval markers` uses: a 0.5 mm uniform shear along x, a 1 mm dent by a 10 mm
/// sphere, a 5 deg twist.
std::vector<MarkerMotion> StandardMarkerMotions();

}  // namespace tac3d
