#include "tac3d/contact/indenter.h"

#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

constexpr double kNoSurface = std::numeric_limits<double>::infinity();

void RequirePositive(const char* what, double value) {
  if (!(value > 0.0 && std::isfinite(value))) {
    throw Error(fmt::format("Indenter: {} must be > 0 and finite, got {}", what, value));
  }
}

// Separation of a circular arc of radius r at distance d from its lowest point.
double ArcSeparation(double radius, double d) {
  return d < radius ? radius - std::sqrt(radius * radius - d * d) : kNoSurface;
}

}  // namespace

Indenter::Indenter(std::function<double(double, double)> separation_mm)
    : separation_mm_(std::move(separation_mm)) {}

Indenter Indenter::Sphere(double radius_mm) {
  RequirePositive("sphere radius_mm", radius_mm);
  return Indenter(
      [radius_mm](double x, double y) { return ArcSeparation(radius_mm, std::hypot(x, y)); });
}

Indenter Indenter::Cylinder(double radius_mm, double axis_angle_rad) {
  RequirePositive("cylinder radius_mm", radius_mm);
  if (!std::isfinite(axis_angle_rad)) throw Error("Indenter: cylinder axis angle is not finite");
  const double c = std::cos(axis_angle_rad), s = std::sin(axis_angle_rad);
  return Indenter(
      [=](double x, double y) { return ArcSeparation(radius_mm, std::abs(-s * x + c * y)); });
}

Indenter Indenter::FlatPunch(double radius_mm) {
  return Pins({Pin{Eigen::Vector2d::Zero(), radius_mm, 0.0}});
}

Indenter Indenter::Pins(std::vector<Pin> pins) {
  if (pins.empty()) throw Error("Indenter: Pins needs at least one pin");
  for (const Pin& pin : pins) {
    RequirePositive("pin radius_mm", pin.radius_mm);
    if (!(pin.recess_mm >= 0.0 && std::isfinite(pin.recess_mm)) || !pin.centre_mm.allFinite()) {
      throw Error(
          fmt::format("Indenter: a pin needs a finite centre and recess_mm >= 0, got "
                      "recess {}",
                      pin.recess_mm));
    }
  }
  return Indenter([pins = std::move(pins)](double x, double y) {
    double h = kNoSurface;
    for (const Pin& pin : pins) {
      if ((Eigen::Vector2d(x, y) - pin.centre_mm).norm() <= pin.radius_mm) {
        h = std::min(h, pin.recess_mm);
      }
    }
    return h;
  });
}

Indenter Indenter::Plane() {
  return Indenter([](double, double) { return 0.0; });
}

Indenter Indenter::HeightFunction(std::function<double(double, double)> separation_mm) {
  if (!separation_mm) throw Error("Indenter: HeightFunction needs a function");
  return Indenter(std::move(separation_mm));
}

double Indenter::Separation(const Eigen::Vector2d& p_in_indenter_mm) const {
  return separation_mm_(p_in_indenter_mm.x(), p_in_indenter_mm.y());
}

Eigen::VectorXd Indenter::CalcGap(const SurfaceGrid& grid,
                                  const Eigen::Vector2d& origin_in_grid_mm) const {
  grid.Validate();
  Eigen::VectorXd gap(grid.num_nodes());
  for (int k = 0; k < grid.num_nodes(); ++k) {
    gap[k] = Separation(grid.node_position_mm(k) - origin_in_grid_mm);
    if (std::isnan(gap[k]) || gap[k] == -kNoSurface) {
      throw Error(fmt::format("Indenter: the separation at node {} is {}", k, gap[k]));
    }
  }
  return gap;
}

}  // namespace tac3d::contact
