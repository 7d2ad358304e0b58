#include "tac3d/friction_eval/friction_evaluation.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numeric>
#include <set>
#include <tuple>
#include <unordered_map>

#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/friction/friction_output.h"
#include "tac3d/scene/scene.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"
#include "tac3d/util/json_number.h"
#include "tac3d/util/percentile.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Nearest point of one object's surface, object frame.
Eigen::Vector3d NearestOnObject(const SceneObject& o, const Eigen::Vector3d& p) {
  switch (o.shape) {
    case SceneObject::Shape::kSphere: {
      const double n = p.norm();
      return n > 0 ? Eigen::Vector3d(p * (o.radius_mm / n)) : Eigen::Vector3d(0, 0, -o.radius_mm);
    }
    case SceneObject::Shape::kCylinder: {  // the lateral surface (the scenes never touch a cap)
      const double rho = std::hypot(p.x(), p.z());
      const double y = std::clamp(p.y(), -0.5 * o.length_mm, 0.5 * o.length_mm);
      if (rho == 0) return {0, y, -o.radius_mm};
      return {p.x() * o.radius_mm / rho, y, p.z() * o.radius_mm / rho};
    }
    case SceneObject::Shape::kBox: {
      const Eigen::Vector3d h = 0.5 * o.size_mm;
      const Eigen::Vector3d clamped = p.cwiseMax(-h).cwiseMin(h);
      if ((p.array().abs() > h.array()).any()) return clamped;
      // Inside: to the nearest face.
      Eigen::Vector3d q = p;
      int axis = 0;
      double best = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a) {
        const double d = h[a] - std::abs(p[a]);
        if (d < best) best = d, axis = a;
      }
      q[axis] = p[axis] < 0 ? -h[axis] : h[axis];
      return q;
    }
    case SceneObject::Shape::kMesh:
      // The triangles the twin's gap caster rasterises; the truth's mu on them is the nearest
      // vertex's (SceneObject::FrictionAt), as the twin simulated it.
      if (!o.mesh || !o.mesh->has_surface()) {
        throw Error(
            fmt::format("friction evaluation: the mesh object '{}' ('{}') has no triangle "
                        "with an area, so no surface",
                        o.name,
                        o.ply_path));
      }
      return o.mesh->ClosestSurfacePoint(p);
    default:
      throw Error(
          fmt::format("friction evaluation: object '{}' is a {}; the truth's surface is "
                      "known for sphere, cylinder, box and mesh only",
                      o.name,
                      ToString(o.shape)));
  }
}

// A uniform hash grid over points for fixed-radius nearest queries.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector3d>& points, double cell_mm)
      : points_(points), cell_(cell_mm) {
    for (size_t i = 0; i < points.size(); ++i)
      cells_[Key(points[i])].push_back(static_cast<int>(i));
  }
  // Nearest point within `radius` (<= the cell size x reach) or -1.
  int Nearest(const Eigen::Vector3d& p, double radius, double* distance = nullptr) const {
    const int reach = static_cast<int>(std::ceil(radius / cell_));
    const auto [cx, cy, cz] = Cell(p);
    int best = -1;
    double best_d2 = radius * radius;
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dz = -reach; dz <= reach; ++dz) {
          const auto it = cells_.find(Pack(cx + dx, cy + dy, cz + dz));
          if (it == cells_.end()) continue;
          for (int i : it->second) {
            const double d2 = (points_[i] - p).squaredNorm();
            if (d2 <= best_d2) best_d2 = d2, best = i;
          }
        }
    if (distance) *distance = best >= 0 ? std::sqrt(best_d2) : kNaN;
    return best;
  }

 private:
  std::tuple<long, long, long> Cell(const Eigen::Vector3d& p) const {
    return {std::lround(std::floor(p.x() / cell_)),
            std::lround(std::floor(p.y() / cell_)),
            std::lround(std::floor(p.z() / cell_))};
  }
  static std::int64_t Pack(long x, long y, long z) {
    const auto u = [](long v) {
      return static_cast<std::int64_t>(v + (1 << 20)) & ((1 << 21) - 1);
    };
    return (u(x) << 42) | (u(y) << 21) | u(z);
  }
  std::int64_t Key(const Eigen::Vector3d& p) const {
    const auto [x, y, z] = Cell(p);
    return Pack(x, y, z);
  }
  const std::vector<Eigen::Vector3d>& points_;
  double cell_;
  std::unordered_map<std::int64_t, std::vector<int>> cells_;
};

// The figures from the sums and counts.
void Finish(FrictionEvaluation& e) {
  const auto ratio = [](double a, double b) { return b > 0 ? a / b : kNaN; };
  e.mu_mae = ratio(e.mu_abs_error_area, e.known_area_mm2);
  e.band_agreement = ratio(e.band_agree_area, e.known_area_mm2);
  e.surface_rms_mm = std::sqrt(ratio(e.surface_sq_area, e.area_mm2));
  e.coverage = ratio(e.covered_points, e.touched_points);
  e.slip_precision = ratio(e.slip_true_positives, e.slip_points - e.slip_points_at_light_slips);
  e.slip_recall = ratio(e.true_slips_found, e.true_slips);
  e.slip_recall_any_cell =
      ratio(e.true_slips_found + e.light_slips_found, e.true_slips + e.light_slips);
  const std::vector<double>& b = e.boundary_distances_mm;
  e.boundary_error_mm = b.empty() ? kNaN : std::accumulate(b.begin(), b.end(), 0.0) / b.size();
  e.boundary_error_median_mm = Percentile(b, 0.5);
  e.boundary_error_p90_mm = Percentile(b, 0.9);
  e.boundary_error_max_mm = b.empty() ? kNaN : *std::max_element(b.begin(), b.end());
}

// Vertex areas: a third of each adjacent triangle's.
std::vector<double> VertexAreas(const friction::FrictionMapResult& map) {
  std::vector<double> area(map.vertices_mm.size(), 0.0);
  for (const Eigen::Vector3i& t : map.triangles) {
    const Eigen::Vector3d& a = map.vertices_mm[t[0]];
    const double third = (map.vertices_mm[t[1]] - a).cross(map.vertices_mm[t[2]] - a).norm() / 6.0;
    for (int k = 0; k < 3; ++k) area[t[k]] += third;
  }
  return area;
}

// The true mu along a straight segment a -> b (world), projected on the true surface.
double TrueMu(const Scene& scene, const Eigen::Vector3d& p_world) {
  const SurfacePoint s = NearestSurfacePoint(scene, p_world);
  return scene.objects[s.object].FrictionAt(s.p_in_object_mm);
}

// Boundary figures: contours of the estimate at the midpoints of materials that meet across
// a mesh edge, and their distance to the true boundary at the same level.
void EvaluateBoundaries(const Scene& scene,
                        const friction::FrictionMapResult& map,
                        const std::vector<double>& true_mu,
                        FrictionEvaluation& e) {
  std::set<std::pair<int, int>> edges;
  for (const Eigen::Vector3i& t : map.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  }
  std::set<std::pair<double, double>> pairs;
  for (const auto& [a, b] : edges) {
    if (true_mu[a] != true_mu[b])
      pairs.insert({std::min(true_mu[a], true_mu[b]), std::max(true_mu[a], true_mu[b])});
  }
  for (const auto& [lo, hi] : pairs) {
    const double level = 0.5 * (lo + hi);
    e.boundary_levels.push_back(level);
    // The true boundary: bisection on edges whose true mu crosses the level.
    std::vector<Eigen::Vector3d> boundary;
    for (const auto& [a, b] : edges) {
      if ((true_mu[a] - level) * (true_mu[b] - level) >= 0) continue;
      Eigen::Vector3d p = map.vertices_mm[a], q = map.vertices_mm[b];
      const bool p_low = true_mu[a] < level;
      for (int i = 0; i < 20; ++i) {
        const Eigen::Vector3d m = 0.5 * (p + q);
        ((TrueMu(scene, m) < level) == p_low ? p : q) = m;
      }
      boundary.push_back(NearestSurfacePoint(scene, 0.5 * (p + q)).p_in_world_mm);
    }
    if (boundary.empty()) continue;
    for (const auto& [a, b] : edges) {
      const double ma = map.mu[a], mb = map.mu[b];
      if (!std::isfinite(ma) || !std::isfinite(mb) || (ma - level) * (mb - level) >= 0) continue;
      const double s = (level - ma) / (mb - ma);
      const Eigen::Vector3d c =
          NearestSurfacePoint(scene,
                              map.vertices_mm[a] + s * (map.vertices_mm[b] - map.vertices_mm[a]))
              .p_in_world_mm;
      double d2 = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector3d& q : boundary) d2 = std::min(d2, (q - c).squaredNorm());
      e.boundary_distances_mm.push_back(std::sqrt(d2));
    }
  }
}

}  // namespace

void FrictionEvaluationOptions::Validate() const {
  if (!(coverage_distance_mm > 0) || !std::isfinite(coverage_distance_mm)) {
    throw Error(fmt::format("FrictionEvaluationOptions::coverage_distance_mm = {} must be > 0",
                            coverage_distance_mm));
  }
  if (!(slip_truth_min_force_n >= 0) || !std::isfinite(slip_truth_min_force_n)) {
    throw Error(fmt::format("FrictionEvaluationOptions::slip_truth_min_force_n = {} must be >= 0",
                            slip_truth_min_force_n));
  }
  if (!(touched_voxel_mm > 0) || !std::isfinite(touched_voxel_mm)) {
    throw Error(fmt::format("FrictionEvaluationOptions::touched_voxel_mm = {} must be > 0",
                            touched_voxel_mm));
  }
}

SurfacePoint NearestSurfacePoint(const Scene& scene, const Eigen::Vector3d& p_in_world_mm) {
  SurfacePoint best;
  best.distance_mm = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& o = scene.objects[i];
    const Eigen::Vector3d p_object = o.world_from_object.inverse() * p_in_world_mm;
    const Eigen::Vector3d q = NearestOnObject(o, p_object);
    const double d = (q - p_object).norm();
    if (d < best.distance_mm) {
      best.distance_mm = d;
      best.p_in_object_mm = q;
      best.p_in_world_mm = o.world_from_object * q;
      best.object = static_cast<int>(i);
    }
  }
  if (best.object < 0) throw Error("friction evaluation: the scene has no object");
  return best;
}

void FrictionReplayRecorder::Add(const TwinStep& step, const TactileFrame& frame) {
  builder_.AddFrame(frame, step.world_from_sensor);
  FrameTruth& t = truth_[frame.index];
  t.marker_slip = step.marker_slip;
  t.measured_contact.assign(frame.forces_n.size(), 0);
  t.true_normal_force_n.clear();
  bool contact = false;
  for (size_t i = 0; i < frame.forces_n.size(); ++i) {
    const double fn = -frame.forces_n[i].dot(frame.normals[i]);
    t.measured_contact[i] = frame.valid[i] && fn > builder_.options().SlipContactThresholdN();
    if (i < step.marker_forces_n.size()) {
      // The true force's normal component along the measured normal (the sensor's z if the
      // marker was not measured).
      const Eigen::Vector3d n = frame.valid[i] ? frame.normals[i] : Eigen::Vector3d::UnitZ();
      t.true_normal_force_n.push_back(-step.marker_forces_n[i].dot(n));
    }
    contact = contact || (frame.valid[i] && fn > builder_.options().contact_threshold_n);
  }
  t.has_previous = previous_ && frame.initialize_progress >= 100;
  if (contact && !previous_) ++strokes_;
  previous_ = contact && frame.initialize_progress >= 100;
  if (!previous_) builder_.BreakStroke();
}

std::vector<Eigen::Vector3d> TouchedTrueSurface(const TwinDatasetReader& dataset,
                                                const Scene& scene,
                                                double voxel_mm,
                                                int max_steps) {
  std::set<std::tuple<long, long, long>> seen;
  std::vector<Eigen::Vector3d> points;
  const std::vector<int>& steps = dataset.steps();
  const size_t count = max_steps > 0 ? std::min<size_t>(max_steps, steps.size()) : steps.size();
  for (size_t k = 0; k < count; ++k) {
    const TwinStep step = dataset.Read(steps[k], /*with_surface=*/true);
    for (size_t i = 0; i < step.surface.states.size(); ++i) {
      if (step.surface.states[i] == ContactState::kSeparated) continue;
      const Eigen::Vector3d p =
          NearestSurfacePoint(scene, step.world_from_sensor * step.surface.positions_mm[i])
              .p_in_world_mm;
      const std::tuple<long, long, long> key{std::lround(std::floor(p.x() / voxel_mm)),
                                             std::lround(std::floor(p.y() / voxel_mm)),
                                             std::lround(std::floor(p.z() / voxel_mm))};
      if (seen.insert(key).second) points.push_back(p);
    }
  }
  return points;
}

FrictionEvaluation EvaluateFrictionMap(
    const Scene& scene,
    const friction::FrictionMapResult& map,
    const std::map<std::int64_t, FrictionReplayRecorder::FrameTruth>& truth,
    const std::vector<Eigen::Vector3d>& touched,
    const FrictionEvaluationOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  FrictionEvaluation e;
  e.scene = scene.name;
  e.map = map.summary;
  e.slip_truth_min_force_n = options.slip_truth_min_force_n;
  const size_t n = map.vertices_mm.size();
  const std::vector<double> area = VertexAreas(map);
  std::vector<double> true_mu(n, kNaN);
  std::vector<Eigen::Vector3d> known_vertices;
  for (size_t v = 0; v < n; ++v) {
    const SurfacePoint s = NearestSurfacePoint(scene, map.vertices_mm[v]);
    true_mu[v] = scene.objects[s.object].FrictionAt(s.p_in_object_mm);
    e.area_mm2 += area[v];
    e.surface_sq_area += area[v] * s.distance_mm * s.distance_mm;
    e.surface_max_mm =
        std::isnan(e.surface_max_mm) ? s.distance_mm : std::max(e.surface_max_mm, s.distance_mm);
    if (!std::isfinite(map.mu[v])) continue;
    known_vertices.push_back(map.vertices_mm[v]);
    e.known_area_mm2 += area[v];
    e.mu_abs_error_area += area[v] * std::abs(map.mu[v] - true_mu[v]);
    if (friction::BandOf(map.mu[v]) == friction::BandOf(true_mu[v])) e.band_agree_area += area[v];
  }
  e.vertices = static_cast<long>(n);
  e.known_vertices = static_cast<long>(known_vertices.size());
  EvaluateBoundaries(scene, map, true_mu, e);

  const PointGrid known(known_vertices, options.coverage_distance_mm);
  e.touched_points = static_cast<long>(touched.size());
  for (const Eigen::Vector3d& p : touched) {
    if (known.Nearest(p, options.coverage_distance_mm) >= 0) ++e.covered_points;
  }

  // A slipping marker is a true slip when pressed over the force floor, else a light slip.
  enum class Truth { kNoSlip, kSlip, kLightSlip };
  const auto truth_of = [&options](const FrictionReplayRecorder::FrameTruth& t, size_t i) {
    if (i >= t.marker_slip.size() || !t.marker_slip[i]) return Truth::kNoSlip;
    const bool pressed = i < t.true_normal_force_n.size() &&
                         t.true_normal_force_n[i] > options.slip_truth_min_force_n;
    return pressed ? Truth::kSlip : Truth::kLightSlip;
  };
  std::set<std::pair<std::int64_t, int>> detected;
  for (const friction::SlipPoint& s : map.slip_points) {
    ++e.slip_points;
    detected.insert({s.frame_index, s.marker});
    const auto it = truth.find(s.frame_index);
    const Truth state = it == truth.end() ? Truth::kNoSlip : truth_of(it->second, s.marker);
    if (state == Truth::kSlip) ++e.slip_true_positives;
    if (state == Truth::kLightSlip) ++e.slip_points_at_light_slips;
  }
  const FrictionReplayRecorder::FrameTruth* previous = nullptr;
  for (const auto& [frame, t] : truth) {
    const FrictionReplayRecorder::FrameTruth* before = previous;
    previous = &t;
    if (!t.has_previous) continue;
    for (size_t i = 0; i < t.marker_slip.size(); ++i) {
      const Truth state = truth_of(t, i);
      if (state == Truth::kNoSlip) continue;
      const bool found = detected.count({frame, static_cast<int>(i)}) > 0;
      if (state == Truth::kLightSlip) {
        ++e.light_slips;
        if (found) ++e.light_slips_found;
        continue;
      }
      ++e.true_slips;
      if (found) {
        ++e.true_slips_found;
      } else {
        const auto in_contact = [i](const FrictionReplayRecorder::FrameTruth* f) {
          return f != nullptr && i < f->measured_contact.size() && f->measured_contact[i];
        };
        if (!in_contact(&t) || !in_contact(before)) ++e.true_slips_missed_no_contact;
      }
    }
  }
  Finish(e);
  e.evaluate_s = SecondsSince(start);
  return e;
}

FrictionEvaluation PoolFrictionEvaluations(const std::vector<FrictionEvaluation>& scenes) {
  FrictionEvaluation all;
  all.scene = "overall";
  if (!scenes.empty()) all.slip_truth_min_force_n = scenes.front().slip_truth_min_force_n;
  for (const FrictionEvaluation& e : scenes) {
    all.vertices += e.vertices;
    all.known_vertices += e.known_vertices;
    all.area_mm2 += e.area_mm2;
    all.known_area_mm2 += e.known_area_mm2;
    all.mu_abs_error_area += e.mu_abs_error_area;
    all.band_agree_area += e.band_agree_area;
    all.surface_sq_area += e.surface_sq_area;
    all.surface_max_mm = std::isnan(all.surface_max_mm)
                             ? e.surface_max_mm
                             : std::max(all.surface_max_mm, e.surface_max_mm);
    all.boundary_distances_mm.insert(all.boundary_distances_mm.end(),
                                     e.boundary_distances_mm.begin(),
                                     e.boundary_distances_mm.end());
    for (double level : e.boundary_levels) {
      if (std::find(all.boundary_levels.begin(), all.boundary_levels.end(), level) ==
          all.boundary_levels.end()) {
        all.boundary_levels.push_back(level);
      }
    }
    all.touched_points += e.touched_points;
    all.covered_points += e.covered_points;
    all.slip_points += e.slip_points;
    all.slip_points_at_light_slips += e.slip_points_at_light_slips;
    all.slip_true_positives += e.slip_true_positives;
    all.true_slips += e.true_slips;
    all.true_slips_found += e.true_slips_found;
    all.true_slips_missed_no_contact += e.true_slips_missed_no_contact;
    all.light_slips += e.light_slips;
    all.light_slips_found += e.light_slips_found;
    all.simulate_s += e.simulate_s;
    all.replay_s += e.replay_s;
    all.map_s += e.map_s;
    all.evaluate_s += e.evaluate_s;
  }
  Finish(all);
  return all;
}

std::string FrictionEvaluation::BriefReport() const {
  return fmt::format(
      "{}: mu_mae {:.4f}, band_agreement {:.4f}, boundary_error {:.3f} mm (p90 {:.3f}), coverage "
      "{:.4f}, "
      "surface_rms {:.4f} mm, slip precision {:.4f} recall {:.4f} ({} slip points, {} true slips "
      "over {} N, {} missed without measured contact; recall {:.4f} counting {} lighter slips)",
      scene,
      mu_mae,
      band_agreement,
      boundary_error_mm,
      boundary_error_p90_mm,
      coverage,
      surface_rms_mm,
      slip_precision,
      slip_recall,
      slip_points,
      true_slips,
      slip_truth_min_force_n,
      true_slips_missed_no_contact,
      slip_recall_any_cell,
      light_slips);
}

nlohmann::json ToJson(const FrictionEvaluation& e, const FrictionTargets& targets) {
  nlohmann::json checks = nlohmann::json::array();
  bool all_pass = true;
  const auto check =
      [&](const char* name, double value, const char* unit, double tolerance, bool at_most) {
        // A scene without a material boundary has no boundary figure: not a failure.
        const bool skip = std::string(name) == "boundary_error_mm" && e.boundary_levels.empty();
        const EvalCheck result =
            skip ? EvalCheck::NotApplicable(
                       name, tolerance,
                       at_most ? EvalCheck::Bound::kAtMost : EvalCheck::Bound::kAtLeast, unit)
            : at_most ? EvalCheck::AtMost(name, value, tolerance, unit)
                      : EvalCheck::AtLeast(name, value, tolerance, unit);
        all_pass = all_pass && result.pass;
        checks.push_back(ToJson(result));
      };
  check("mu_mae", e.mu_mae, "", targets.mu_mae, true);
  check("band_agreement", e.band_agreement, "", targets.band_agreement, false);
  check("boundary_error_mm", e.boundary_error_mm, "mm", targets.boundary_error_mm, true);
  check("coverage", e.coverage, "", targets.coverage, false);
  check("surface_rms_mm", e.surface_rms_mm, "mm", targets.surface_rms_mm, true);
  check("slip_precision", e.slip_precision, "", targets.slip_precision, false);
  check("slip_recall", e.slip_recall, "", targets.slip_recall, false);
  return {
      {"scene", e.scene},
      {"mu_mae", FiniteOrNull(e.mu_mae)},
      {"mu_mae_weighting", "area (a third of each adjacent triangle), vertices with a known mu"},
      {"band_agreement", FiniteOrNull(e.band_agreement)},
      {"boundary_error_mm", FiniteOrNull(e.boundary_error_mm)},
      {"boundary_error_median_mm", FiniteOrNull(e.boundary_error_median_mm)},
      {"boundary_error_p90_mm", FiniteOrNull(e.boundary_error_p90_mm)},
      {"boundary_error_max_mm", FiniteOrNull(e.boundary_error_max_mm)},
      {"boundary_levels", e.boundary_levels},
      {"boundary_contour_points", e.boundary_distances_mm.size()},
      {"coverage", FiniteOrNull(e.coverage)},
      {"surface_rms_mm", FiniteOrNull(e.surface_rms_mm)},
      {"surface_max_mm", FiniteOrNull(e.surface_max_mm)},
      {"slip_precision", FiniteOrNull(e.slip_precision)},
      {"slip_recall", FiniteOrNull(e.slip_recall)},
      {"slip_recall_any_cell", FiniteOrNull(e.slip_recall_any_cell)},
      {"slip_truth_min_force_n", e.slip_truth_min_force_n},
      {"vertices", e.vertices},
      {"known_vertices", e.known_vertices},
      {"area_mm2", e.area_mm2},
      {"known_area_mm2", e.known_area_mm2},
      {"touched_points", e.touched_points},
      {"covered_points", e.covered_points},
      {"slip_points", e.slip_points},
      {"slip_points_at_light_slips", e.slip_points_at_light_slips},
      {"slip_true_positives", e.slip_true_positives},
      {"true_slips", e.true_slips},
      {"true_slips_found", e.true_slips_found},
      {"true_slips_missed_no_contact", e.true_slips_missed_no_contact},
      {"light_slips", e.light_slips},
      {"light_slips_found", e.light_slips_found},
      {"map", e.scene == "overall" ? nlohmann::json() : friction::ToJson(e.map)},
      {"seconds",
       {{"simulate", e.simulate_s},
        {"replay", e.replay_s},
        {"map", e.map_s},
        {"evaluate", e.evaluate_s}}},
      {"checks", checks},
      {"all_pass", all_pass}};
}

}  // namespace tac3d
