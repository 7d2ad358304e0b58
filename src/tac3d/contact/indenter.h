#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "tac3d/contact/compliance.h"

namespace tac3d::contact {

/// A flat-ended cylindrical pin of Indenter::Pins.
struct Pin {
  Eigen::Vector2d centre_mm = Eigen::Vector2d::Zero();
  double radius_mm = 0.5;
  /// How far this pin's face stands back from the indenter's reference plane (>= 0), so pins
  /// of uneven length touch one after another.
  double recess_mm = 0.0;
};

/// A rigid indenter as its profile: the separation h(x, y) (mm) between its surface and the
/// flat, undeformed contact surface when its reference point (the lowest point of a sphere,
/// cylinder or punch face) touches the surface at the indenter's origin. +infinity where the
/// indenter has no surface facing the body (outside a punch's face, beyond a sphere's
/// equator): such nodes can never come into contact.
class Indenter {
 public:
  /// A sphere: h = R - sqrt(R^2 - r^2) (exact, not Hertz's parabola).
  static Indenter Sphere(double radius_mm);
  /// A cylinder lying on the surface, its axis along (cos angle, sin angle):
  /// h = R - sqrt(R^2 - d^2), d the distance from the axis' trace.
  static Indenter Cylinder(double radius_mm, double axis_angle_rad);
  /// A flat-ended circular punch: h = 0 on its face r <= radius.
  static Indenter FlatPunch(double radius_mm);
  /// Several flat punches; where faces overlap the nearer one counts.
  static Indenter Pins(std::vector<Pin> pins);
  /// A flat plane parallel to the surface: h = 0 everywhere.
  static Indenter Plane();
  /// Any profile: the hook for scenes' objects. `separation_mm(x, y)` must return a finite
  /// value or +infinity (no surface there).
  static Indenter HeightFunction(std::function<double(double x_mm, double y_mm)> separation_mm);

  /// h at the point (mm) in the indenter's own coordinates.
  double Separation(const Eigen::Vector2d& p_in_indenter_mm) const;
  /// h at every node of the grid with the indenter's origin at `origin_in_grid_mm`.
  /// @throws tac3d::Error if a value is NaN or -infinity (a broken height function).
  Eigen::VectorXd CalcGap(const SurfaceGrid& grid, const Eigen::Vector2d& origin_in_grid_mm) const;

 private:
  explicit Indenter(std::function<double(double, double)> separation_mm);
  std::function<double(double, double)> separation_mm_;
};

}  // namespace tac3d::contact
