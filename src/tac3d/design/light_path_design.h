#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/sensor/sensor_config.h"
// DefaultSensorConfig was declared here; kept visible to this header's existing users.
#include "tac3d/sensor/default_sensor.h"  // IWYU pragma: export

namespace tac3d {

/// The light-path design problem of the paper (section III.B, Fig. 4), for the left half in
/// the x-z plane of the sensor frame; the right half is its mirror image.
struct LightPathDesignOptions {
  double h_mm = 40.0;     ///< camera centre O to the elastic body's face (z = 0)
  double l_mm = 40.0;     ///< fingertip length: A0 = (-l/2, 0), B0 = (l/2, 0)
  double d_mm = 8.0;      ///< elastic body thickness (mirrors must stay below the body)
  double fov_deg = 48.0;  ///< the camera's horizontal field of view (phi)
  /// Newton starts per unknown for the root enumeration (starts_per_axis^4 in all).
  int starts_per_axis = 8;
  /// Extra length of the outer mirror beyond its two rays, as a fraction of its length.
  double outer_mirror_margin = 0.02;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// A point of the left half's x-z plane mirrored into the right half's (x -> -x).
inline Eigen::Vector2d MirrorX(const Eigen::Vector2d& p) { return {-p.x(), p.y()}; }

/// One root of the four design equations, with everything it implies (x, z in mm).
struct LightPathRoot {
  /// Unknowns: height of mirror 2's apex B2 on the axis, direction of mirror 2, and mirror
  /// 1's line {p : n(a1) . p = c1}.
  Eigen::Vector4d unknowns = Eigen::Vector4d::Zero();
  Eigen::Vector2d camera, center, a0, b0, a1, b1, a2, b2;  ///< O, M and the paper's points
  Eigen::Vector2d virtual_camera;                          ///< O' (left virtual camera)
  Eigen::Vector4d residuals = Eigen::Vector4d::Zero();     ///< of the four equations
  double parallax_deg = 0.0;                               ///< angle O'MO''
  std::vector<std::string> rejections;                     ///< why it is impossible

  bool valid() const { return rejections.empty(); }
  double max_residual() const { return residuals.cwiseAbs().maxCoeff(); }
};

struct LightPathDesign {
  std::vector<LightPathRoot> roots;  ///< every distinct root found, valid ones first
  std::optional<int> chosen;         ///< the valid root used (the first), if any
  /// The sensor with the chosen layout: camera at (0, 0, -h), mirrors 1-4, virtual cameras.
  std::optional<SensorConfig> config;
  struct Summary {
    int starts = 0;
    int converged = 0;
    int distinct_roots = 0;
    int valid_roots = 0;
    double seconds = 0.0;
  } summary;
};

/// Solves the four equations (A0 and B0 reach O half a field of view apart; reflections
/// specular; A2 on the line B0B1 with B2 on the axis; angle O'MO'' = 90 deg) from a grid
/// of starts, keeps the distinct roots, rejects the impossible ones with the reason, and
/// writes the first valid layout into a copy of `base` (camera, light path, mirrors,
/// virtual cameras; the other sections are kept).
/// @throws Error if the options are invalid (not if no layout is possible: then
/// `chosen` is empty and every root says why it was rejected).
LightPathDesign DesignLightPath(const LightPathDesignOptions& options,
                                const SensorConfig& base = SensorConfig{});

/// The design problem of a sensor: its light path's h, l, d and field of view.
LightPathDesignOptions DesignOptionsOf(const SensorConfig& sensor);

}  // namespace tac3d
