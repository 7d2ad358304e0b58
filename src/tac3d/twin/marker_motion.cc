#include "tac3d/twin/marker_motion.h"

#include <cmath>

#include "tac3d/geometry/geometry.h"

namespace tac3d {

std::vector<Eigen::Vector3d> MarkerMotion::Apply(const std::vector<Eigen::Vector3d>& markers) const {
  std::vector<Eigen::Vector3d> moved = markers;
  switch (kind) {
    case MarkerMotionKind::kShear:
      for (auto& p : moved) p += shear_mm;
      break;
    case MarkerMotionKind::kDent: {
      // The sphere's lowest point sits dent_depth_mm under the highest marker; a marker
      // under the sphere is pushed down onto it, with the surface following it smoothly.
      double top = -1e9;
      for (const auto& p : markers) top = std::max(top, p.z());
      const double bottom = top - dent_depth_mm;
      const double r = dent_sphere_radius_mm;
      for (auto& p : moved) {
        const double rho2 = p.head<2>().squaredNorm();
        if (rho2 >= r * r) continue;
        const double sphere_z = bottom + r - std::sqrt(r * r - rho2);
        if (p.z() > sphere_z) p.z() = sphere_z;
      }
      break;
    }
    case MarkerMotionKind::kTwist:
      for (auto& p : moved) {
        const double rho2 = p.head<2>().squaredNorm();
        const double angle =
            DegToRad(twist_deg) * std::exp(-rho2 / (twist_fade_radius_mm * twist_fade_radius_mm));
        const double c = std::cos(angle), s = std::sin(angle);
        p.head<2>() = Eigen::Vector2d(c * p.x() - s * p.y(), s * p.x() + c * p.y());
      }
      break;
  }
  return moved;
}

std::vector<MarkerMotion> StandardMarkerMotions() {
  MarkerMotion shear;
  shear.kind = MarkerMotionKind::kShear;
  shear.name = "shear_0.5mm";
  MarkerMotion dent;
  dent.kind = MarkerMotionKind::kDent;
  dent.name = "dent_1mm";
  MarkerMotion twist;
  twist.kind = MarkerMotionKind::kTwist;
  twist.name = "twist_5deg";
  return {shear, dent, twist};
}

}  // namespace tac3d
