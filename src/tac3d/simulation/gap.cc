#include "tac3d/simulation/gap.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d::simulation {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The parameter interval [lo, hi] where a convex piece holds the line (empty if lo > hi).
struct Interval {
  double lo = -kInf;
  double hi = kInf;
  bool empty() const { return !(lo <= hi); }
  void Intersect(const Interval& other) {
    lo = std::max(lo, other.lo);
    hi = std::min(hi, other.hi);
  }
};

constexpr Interval kEmpty{kInf, -kInf};

// lo <= o_k + t d_k <= hi.
Interval Slab(const Eigen::Vector3d& o, const Eigen::Vector3d& d, int k, double lo, double hi) {
  if (std::abs(d[k]) < 1e-12) return o[k] >= lo && o[k] <= hi ? Interval{} : kEmpty;
  const double t1 = (lo - o[k]) / d[k], t2 = (hi - o[k]) / d[k];
  return {std::min(t1, t2), std::max(t1, t2)};
}

// |p - (p.a) a| <= r for the unit axis a through the origin.
Interval InfiniteCylinder(const Eigen::Vector3d& o,
                          const Eigen::Vector3d& d,
                          const Eigen::Vector3d& axis,
                          double r) {
  const Eigen::Vector3d op = o - o.dot(axis) * axis, dp = d - d.dot(axis) * axis;
  const double a = dp.squaredNorm(), b = op.dot(dp), c = op.squaredNorm() - r * r;
  if (a < 1e-24) return c <= 0.0 ? Interval{} : kEmpty;
  const double disc = b * b - a * c;
  if (disc < 0.0) return kEmpty;
  const double root = std::sqrt(disc);
  return {(-b - root) / a, (-b + root) / a};
}

Interval FlatPunch(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r) {
  Interval i = InfiniteCylinder(o, d, Eigen::Vector3d::UnitZ(), r);
  i.Intersect(Slab(o, d, 2, 0.0, kInf));
  return i;
}

// Signed distance from p to a flat punch of radius r whose edge is rounded with e: the points
// within e of the cylinder {rho <= r - e, z >= e} (exact, so a march by it never overshoots).
double RoundedPunchDistance(const Eigen::Vector3d& p, double r, double e) {
  const double qx = p.head<2>().norm() - (r - e), qz = e - p.z();
  return std::hypot(std::max(qx, 0.0), std::max(qz, 0.0)) + std::min(std::max(qx, qz), 0.0) - e;
}

// A flat punch of radius r with its edge rounded with e (0 < e <= r). Along the axis the face
// is z_b(rho) = e - sqrt(e^2 - (rho - r + e)^2) in the rim, 0 inside it (closed form); any
// other line is marched by the distance (convex body) from both ends of the sharp punch's
// interval, which holds the rounded one.
Interval RoundedPunch(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, double e) {
  if (d.head<2>().norm() < 1e-12) {
    const double rim = o.head<2>().norm() - (r - e);
    const double face_z = rim > 0.0 && rim <= e ? e - std::sqrt(e * e - rim * rim) : 0.0;
    Interval i = InfiniteCylinder(o, d, Eigen::Vector3d::UnitZ(), r);
    i.Intersect(Slab(o, d, 2, face_z, kInf));
    return i;
  }
  const Interval sharp = FlatPunch(o, d, r);
  if (sharp.empty() || !std::isfinite(sharp.lo) || !std::isfinite(sharp.hi)) return sharp;
  constexpr double kOnSurfaceMm = 1e-10;
  const auto march = [&](double t, double direction) -> std::optional<double> {
    for (int k = 0; k < 500 && t >= sharp.lo && t <= sharp.hi; ++k) {
      const double distance = RoundedPunchDistance(o + t * d, r, e);
      if (distance <= kOnSurfaceMm) return t;
      t += direction * distance;
    }
    return std::nullopt;  // past the other end: the line misses the rounded edge
  };
  const std::optional<double> entry = march(sharp.lo, 1.0), exit = march(sharp.hi, -1.0);
  if (!entry || !exit) return kEmpty;
  return {*entry, *exit};
}

Interval AnalyticInterval(const SceneObject& s,
                          const Eigen::Vector3d& o,
                          const Eigen::Vector3d& d) {
  switch (s.shape) {
    case SceneObject::Shape::kSphere: {
      const double b = o.dot(d), c = o.squaredNorm() - s.radius_mm * s.radius_mm;
      const double disc = b * b - c;
      if (disc < 0.0) return kEmpty;
      const double root = std::sqrt(disc);
      return {-b - root, -b + root};
    }
    case SceneObject::Shape::kCylinder: {
      Interval i = InfiniteCylinder(o, d, Eigen::Vector3d::UnitY(), s.radius_mm);
      i.Intersect(Slab(o, d, 1, -0.5 * s.length_mm, 0.5 * s.length_mm));
      return i;
    }
    case SceneObject::Shape::kFlatPunch:
      return s.edge_radius_mm > 0.0 ? RoundedPunch(o, d, s.radius_mm, s.edge_radius_mm)
                                    : FlatPunch(o, d, s.radius_mm);
    case SceneObject::Shape::kPins: {
      Interval best = kEmpty;
      for (int r = 0; r < s.rows; ++r) {
        for (int c = 0; c < s.cols; ++c) {
          const Eigen::Vector3d centre(
              (c - 0.5 * (s.cols - 1)) * s.pitch_mm, (r - 0.5 * (s.rows - 1)) * s.pitch_mm, 0.0);
          const Interval i = FlatPunch(o - centre, d, s.radius_mm);
          if (!i.empty() && i.hi > 0.0 && (best.empty() || i.lo < best.lo)) best = i;
        }
      }
      return best;
    }
    case SceneObject::Shape::kBox: {
      Interval i;
      for (int k = 0; k < 3; ++k)
        i.Intersect(Slab(o, d, k, -0.5 * s.size_mm[k], 0.5 * s.size_mm[k]));
      return i;
    }
    case SceneObject::Shape::kMesh:
      break;
  }
  TAC3D_DEMAND(false);
  return kEmpty;
}

}  // namespace

std::optional<LineEntry> IntersectAnalyticObject(const SceneObject& object,
                                                 const Eigen::Vector3d& origin_object,
                                                 const Eigen::Vector3d& direction_object) {
  TAC3D_DEMAND(object.shape != SceneObject::Shape::kMesh);
  const Interval i = AnalyticInterval(object, origin_object, direction_object);
  if (i.empty() || !(i.hi > 0.0) || !std::isfinite(i.lo)) return std::nullopt;
  return LineEntry{i.lo, origin_object + i.lo * direction_object};
}

GapCaster::GapCaster(const std::vector<SceneObject>& objects,
                     const contact::SurfaceGrid& grid,
                     std::vector<Eigen::Vector3d> surface_points_mm,
                     std::vector<bool> active)
    : objects_(objects),
      grid_(grid),
      points_(std::move(surface_points_mm)),
      active_(std::move(active)),
      crossings_(grid.num_nodes()) {
  grid_.Validate();
  TAC3D_DEMAND(static_cast<int>(points_.size()) == grid_.num_nodes());
  TAC3D_DEMAND(static_cast<int>(active_.size()) == grid_.num_nodes());
}

void GapCaster::CastMesh(const SceneObject& object, const Rigid3& sensor_from_object) const {
  for (auto& c : crossings_) c.clear();
  const TriangleMesh& mesh = object.mesh->mesh();
  std::vector<Eigen::Vector3d> v(mesh.vertices.size());
  for (size_t k = 0; k < v.size(); ++k) v[k] = sensor_from_object * mesh.vertices[k];
  // The grid's nodes sit under their surface points (the grid is relative to the dome's axis).
  const double x0 = points_[0].x(), y0 = points_[0].y();
  for (const Eigen::Vector3i& tri : mesh.triangles) {
    const Eigen::Vector3d &a = v[tri[0]], &b = v[tri[1]], &c = v[tri[2]];
    const double area2 = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (std::abs(area2) < 1e-14) continue;  // edge-on to the lines
    const int i_lo = std::max(
        0, static_cast<int>(std::ceil((std::min({a.x(), b.x(), c.x()}) - x0) / grid_.dx_mm)));
    const int i_hi = std::min(
        grid_.nx - 1,
        static_cast<int>(std::floor((std::max({a.x(), b.x(), c.x()}) - x0) / grid_.dx_mm)));
    const int j_lo = std::max(
        0, static_cast<int>(std::ceil((std::min({a.y(), b.y(), c.y()}) - y0) / grid_.dy_mm)));
    const int j_hi = std::min(
        grid_.ny - 1,
        static_cast<int>(std::floor((std::max({a.y(), b.y(), c.y()}) - y0) / grid_.dy_mm)));
    // A counter-clockwise triangle seen from +z has its outward normal along +z: an exit.
    const bool entering = area2 < 0.0;
    for (int j = j_lo; j <= j_hi; ++j) {
      for (int i = i_lo; i <= i_hi; ++i) {
        const int node = j * grid_.nx + i;
        if (!active_[node]) continue;
        const Eigen::Vector3d& p = points_[node];
        // Barycentric coordinates of p's (x, y) (half-open edges would be exact; a line
        // through a shared edge may count twice, which the interval walk tolerates).
        const double w1 =
            ((c.x() - b.x()) * (p.y() - b.y()) - (c.y() - b.y()) * (p.x() - b.x())) / area2;
        const double w2 =
            ((a.x() - c.x()) * (p.y() - c.y()) - (a.y() - c.y()) * (p.x() - c.x())) / area2;
        const double w3 = 1.0 - w1 - w2;
        if (w1 < 0.0 || w2 < 0.0 || w3 < 0.0) continue;
        const double z = w1 * a.z() + w2 * b.z() + w3 * c.z();
        crossings_[node].emplace_back(z - p.z(), entering);
      }
    }
  }
}

GapField GapCaster::Cast(const Rigid3& world_from_sensor) const {
  const int n = grid_.num_nodes();
  GapField field;
  field.gap_mm = Eigen::VectorXd::Constant(n, kInf);
  field.friction_coefficient = Eigen::VectorXd::Zero(n);
  field.object.assign(n, -1);
  for (int o = 0; o < static_cast<int>(objects_.size()); ++o) {
    const SceneObject& object = objects_[o];
    const Rigid3 object_from_sensor = object.world_from_object.inverse() * world_from_sensor;
    const Eigen::Vector3d d = object_from_sensor.linear() * Eigen::Vector3d::UnitZ();
    if (object.shape == SceneObject::Shape::kMesh) {
      CastMesh(object, object_from_sensor.inverse());
      for (int i = 0; i < n; ++i) {
        auto& c = crossings_[i];
        if (c.empty()) continue;
        std::sort(c.begin(), c.end());
        double entry = kInf;
        bool inside = false;
        for (const auto& [t, entering] : c) {
          if (entering) {
            if (!inside) entry = t;
            inside = true;
          } else if (inside) {
            if (t > 0.0) break;
            inside = false;
            entry = kInf;
          }
        }
        if (entry < field.gap_mm[i]) {
          field.gap_mm[i] = entry;
          field.object[i] = o;
          field.friction_coefficient[i] = object.FrictionAt(
              object_from_sensor * (points_[i] + entry * Eigen::Vector3d::UnitZ()));
        }
      }
      continue;
    }
    for (int i = 0; i < n; ++i) {
      if (!active_[i]) continue;
      const std::optional<LineEntry> hit =
          IntersectAnalyticObject(object, object_from_sensor * points_[i], d);
      if (hit && hit->t_mm < field.gap_mm[i]) {
        field.gap_mm[i] = hit->t_mm;
        field.object[i] = o;
        field.friction_coefficient[i] = object.FrictionAt(hit->p_object);
      }
    }
  }
  return field;
}

}  // namespace tac3d::simulation
