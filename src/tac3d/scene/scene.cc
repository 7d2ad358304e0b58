#include "tac3d/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

void Require(bool ok, const std::string& field, const std::string& bound, double value) {
  if (!ok || std::isnan(value)) {
    throw Error(fmt::format("scene: {} = {} is out of range: must be {}", field, value, bound));
  }
}

std::string Resolve(const std::string& base_dir, const std::string& path) {
  return fs::path(path).is_absolute() || base_dir.empty() ? path : (fs::path(base_dir) / path).string();
}

Rigid3 ReadPose(YamlReader& r) {
  return PoseFromRpy(r.Vector<3>("position_mm"), r.Vector<3>("rpy_deg", Eigen::Vector3d::Zero()));
}

FrictionMap ReadFriction(YamlReader r) {
  FrictionMap map;
  map.default_mu = r.Double("default");
  map.vertex_property = r.String("vertex_property", "");
  if (r.Has("regions")) {
    const YAML::Node regions = r.Sequence("regions");
    for (size_t i = 0; i < regions.size(); ++i) {
      YamlReader e = r.Element(regions, "regions", i);
      FrictionRegion region;
      region.mu = e.Double("mu");
      if (e.Has("box_min_mm") || e.Has("box_max_mm")) {
        region.kind = FrictionRegion::Kind::kBox;
        region.min_mm = e.Vector<3>("box_min_mm");
        region.max_mm = e.Vector<3>("box_max_mm");
      } else if (e.Has("ball_center_mm") || e.Has("ball_radius_mm")) {
        region.kind = FrictionRegion::Kind::kBall;
        region.center_mm = e.Vector<3>("ball_center_mm");
        region.radius_mm = e.Double("ball_radius_mm");
      } else {
        e.Fail(e.Join("mu"), "a region needs box_min_mm/box_max_mm or ball_center_mm/ball_radius_mm");
      }
      map.regions.push_back(region);
    }
  }
  return map;
}

SceneObject ReadObject(YamlReader r, const std::string& base_dir) {
  SceneObject o;
  o.name = r.String("name");
  const std::string shape = r.String("shape");
  if (shape == "sphere") {
    o.shape = SceneObject::Shape::kSphere;
    o.radius_mm = r.Double("radius_mm");
  } else if (shape == "cylinder") {
    o.shape = SceneObject::Shape::kCylinder;
    o.radius_mm = r.Double("radius_mm");
    o.length_mm = r.Double("length_mm");
  } else if (shape == "flat_punch") {
    o.shape = SceneObject::Shape::kFlatPunch;
    o.radius_mm = r.Double("radius_mm");
    if (r.Has("edge_radius_mm")) o.edge_radius_mm = r.Double("edge_radius_mm");
  } else if (shape == "pins") {
    o.shape = SceneObject::Shape::kPins;
    o.radius_mm = r.Double("radius_mm");
    o.rows = r.Int("rows");
    o.cols = r.Int("cols");
    o.pitch_mm = r.Double("pitch_mm");
  } else if (shape == "box") {
    o.shape = SceneObject::Shape::kBox;
    o.size_mm = r.Vector<3>("size_mm");
  } else if (shape == "mesh") {
    o.shape = SceneObject::Shape::kMesh;
    o.ply_path = r.String("ply");
    o.mesh = std::make_shared<const IndexedMesh>(ReadPly(Resolve(base_dir, o.ply_path)));
  } else {
    r.Fail(r.Join("shape"), fmt::format("'{}' is not one of sphere, cylinder, flat_punch, pins, box, mesh", shape));
  }
  o.world_from_object = ReadPose(r);
  o.friction = ReadFriction(r.Child("friction"));
  return o;
}

Trajectory ReadTrajectory(YamlReader r, const std::string& base_dir) {
  Trajectory t;
  t.steps = r.Int("steps");
  if (r.Has("csv")) {
    t.keyframes = ReadTrajectoryCsv(Resolve(base_dir, r.String("csv")));
  } else {
    const YAML::Node keyframes = r.Sequence("keyframes");
    for (size_t i = 0; i < keyframes.size(); ++i) {
      YamlReader k = r.Element(keyframes, "keyframes", i);
      t.keyframes.push_back({k.Double("t_s"), ReadPose(k)});
    }
  }
  if (r.Has("tangential_load")) {
    YamlReader l = r.Child("tangential_load");
    TangentialLoadRamp ramp;
    ramp.start_s = l.Double("start_s");
    ramp.rate_per_s = l.Double("rate_per_s");
    ramp.final_load = l.Double("final_load");
    ramp.direction_deg = l.Double("direction_deg", 0.0);
    t.tangential_load = ramp;
  }
  return t;
}

}  // namespace

std::string_view ToString(SceneObject::Shape shape) {
  switch (shape) {
    case SceneObject::Shape::kSphere: return "sphere";
    case SceneObject::Shape::kCylinder: return "cylinder";
    case SceneObject::Shape::kFlatPunch: return "flat_punch";
    case SceneObject::Shape::kPins: return "pins";
    case SceneObject::Shape::kBox: return "box";
    case SceneObject::Shape::kMesh: return "mesh";
  }
  return "?";
}

// ---- IndexedMesh -------------------------------------------------------------------------

namespace {

// The point of triangle abc nearest to p (Ericson, Real-Time Collision Detection, 5.1.5): by
// the Voronoi region of the triangle's features that holds p.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p,
                                       const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace

IndexedMesh::IndexedMesh(TriangleMesh mesh) : mesh_(std::move(mesh)) {
  if (mesh_.vertices.empty()) throw Error("mesh: no vertices");
  const int num_vertices = static_cast<int>(mesh_.vertices.size());
  for (size_t t = 0; t < mesh_.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh_.triangles[t];
    if (tri.minCoeff() < 0 || tri.maxCoeff() >= num_vertices) {
      throw Error(
          fmt::format("mesh: triangle {} indexes a vertex out of 0..{}", t, num_vertices - 1));
    }
  }
  Eigen::Vector3d lo = mesh_.vertices.front(), hi = lo;
  for (const Eigen::Vector3d& v : mesh_.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  // About two vertices a cell on average for a surface mesh filling its box's faces, and at
  // most 512 cells an axis.
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-9);
  cell_mm_ = std::max(
      {std::sqrt(2.0 *
                 (extent.x() * extent.y() + extent.y() * extent.z() + extent.z() * extent.x()) /
                 (mesh_.vertices.size() / 2.0 + 1)),
       extent.maxCoeff() / 511.0,
       1e-6});
  origin_ = lo;
  cells_ = ((extent / cell_mm_).array().floor().cast<int>() + 1).matrix();
  buckets_.resize(static_cast<size_t>(cells_.x()) * cells_.y() * cells_.z());
  for (int i = 0; i < num_vertices; ++i) {
    const Eigen::Vector3i c = CellOf(mesh_.vertices[i]);
    buckets_[CellIndex(c.x(), c.y(), c.z())].push_back(i);
  }
  // Triangles into the cells their bounding boxes overlap, in two passes (count, then fill).
  const auto for_each_cell = [&](int t, const auto& visit) {
    const Eigen::Vector3i& tri = mesh_.triangles[t];
    const Eigen::Vector3d& a = mesh_.vertices[tri[0]];
    const Eigen::Vector3d& b = mesh_.vertices[tri[1]];
    const Eigen::Vector3d& c = mesh_.vertices[tri[2]];
    const Eigen::Vector3i from = CellOf(a.cwiseMin(b).cwiseMin(c));
    const Eigen::Vector3i to = CellOf(a.cwiseMax(b).cwiseMax(c));
    for (int z = from.z(); z <= to.z(); ++z)
      for (int y = from.y(); y <= to.y(); ++y)
        for (int x = from.x(); x <= to.x(); ++x) visit(CellIndex(x, y, z));
  };
  for (int t = 0; t < static_cast<int>(mesh_.triangles.size()); ++t) {
    const Eigen::Vector3i& tri = mesh_.triangles[t];
    const Eigen::Vector3d ab = mesh_.vertices[tri[1]] - mesh_.vertices[tri[0]];
    const Eigen::Vector3d ac = mesh_.vertices[tri[2]] - mesh_.vertices[tri[0]];
    const Eigen::Vector3d bc = mesh_.vertices[tri[2]] - mesh_.vertices[tri[1]];
    const double longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
    if (ab.cross(ac).norm() > 1e-12 * longest2) surface_triangles_.push_back(t);
  }
  triangle_cell_start_.assign(buckets_.size() + 1, 0);
  for (const int t : surface_triangles_)
    for_each_cell(t, [&](size_t cell) { ++triangle_cell_start_[cell + 1]; });
  for (size_t i = 1; i < triangle_cell_start_.size(); ++i)
    triangle_cell_start_[i] += triangle_cell_start_[i - 1];
  triangle_cells_.resize(triangle_cell_start_.back());
  std::vector<int> filled(triangle_cell_start_.begin(), triangle_cell_start_.end() - 1);
  for (const int t : surface_triangles_)
    for_each_cell(t, [&](size_t cell) { triangle_cells_[filled[cell]++] = t; });
}

Eigen::Vector3i IndexedMesh::CellOf(const Eigen::Vector3d& p) const {
  Eigen::Vector3i c = ((p - origin_) / cell_mm_).array().floor().cast<int>();
  return c.cwiseMax(0).cwiseMin(cells_ - Eigen::Vector3i::Ones());
}

int IndexedMesh::NearestVertex(const Eigen::Vector3d& p) const {
  const Eigen::Vector3i center = CellOf(p);
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  const int max_ring = cells_.maxCoeff();
  for (int ring = 0; ring <= max_ring; ++ring) {
    for (int z = center.z() - ring; z <= center.z() + ring; ++z) {
      for (int y = center.y() - ring; y <= center.y() + ring; ++y) {
        for (int x = center.x() - ring; x <= center.x() + ring; ++x) {
          const bool on_shell = std::max({std::abs(x - center.x()), std::abs(y - center.y()),
                                          std::abs(z - center.z())}) == ring;
          if (!on_shell || x < 0 || y < 0 || z < 0 || x >= cells_.x() || y >= cells_.y() || z >= cells_.z()) {
            continue;
          }
          for (int i : buckets_[CellIndex(x, y, z)]) {
            const double d2 = (mesh_.vertices[i] - p).squaredNorm();
            if (d2 < best_d2) {
              best_d2 = d2;
              best = i;
            }
          }
        }
      }
    }
    // Every cell beyond this ring is at least `ring` cells away from p's cell.
    if (best >= 0 && std::sqrt(best_d2) <= ring * cell_mm_) break;
  }
  return best;
}

Eigen::Vector3d IndexedMesh::ClosestSurfacePoint(const Eigen::Vector3d& p) const {
  if (!has_surface()) throw Error("mesh: no triangle with an area, so no surface");
  const Eigen::Vector3i center = CellOf(p);
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  double best_d2 = std::numeric_limits<double>::infinity();
  const int max_ring = cells_.maxCoeff();
  for (int ring = 0; ring <= max_ring; ++ring) {
    for (int z = std::max(center.z() - ring, 0); z <= std::min(center.z() + ring, cells_.z() - 1);
         ++z) {
      for (int y = std::max(center.y() - ring, 0); y <= std::min(center.y() + ring, cells_.y() - 1);
           ++y) {
        for (int x = std::max(center.x() - ring, 0);
             x <= std::min(center.x() + ring, cells_.x() - 1);
             ++x) {
          if (std::max(
                  {std::abs(x - center.x()), std::abs(y - center.y()), std::abs(z - center.z())}) !=
              ring) {
            continue;
          }
          const size_t cell = CellIndex(x, y, z);
          // A triangle in several cells is tested once a cell: cheaper than remembering it.
          for (int k = triangle_cell_start_[cell]; k < triangle_cell_start_[cell + 1]; ++k) {
            const Eigen::Vector3i& tri = mesh_.triangles[triangle_cells_[k]];
            const Eigen::Vector3d q = ClosestPointOnTriangle(
                p, mesh_.vertices[tri[0]], mesh_.vertices[tri[1]], mesh_.vertices[tri[2]]);
            const double d2 = (q - p).squaredNorm();
            if (d2 < best_d2) {
              best_d2 = d2;
              best = q;
            }
          }
        }
      }
    }
    // A triangle's nearest point lies in a cell it is listed in; every cell beyond this ring
    // is at least `ring` cells away from p's cell.
    if (std::sqrt(best_d2) <= ring * cell_mm_) break;
  }
  return best;
}

// ---- Friction ----------------------------------------------------------------------------

bool FrictionRegion::Contains(const Eigen::Vector3d& p) const {
  if (kind == Kind::kBall) return (p - center_mm).norm() <= radius_mm;
  return (p.array() >= min_mm.array()).all() && (p.array() <= max_mm.array()).all();
}

double SceneObject::FrictionAt(const Eigen::Vector3d& p_object) const {
  if (mesh && !friction.vertex_property.empty()) {
    return mesh->mesh().vertex_properties.at(friction.vertex_property)[mesh->NearestVertex(p_object)];
  }
  for (const FrictionRegion& region : friction.regions) {
    if (region.Contains(p_object)) return region.mu;
  }
  return friction.default_mu;
}

// ---- Trajectory --------------------------------------------------------------------------

Rigid3 PoseFromRpy(const Eigen::Vector3d& position_mm, const Eigen::Vector3d& rpy_deg) {
  const Eigen::Vector3d r = rpy_deg * M_PI / 180.0;
  Rigid3 pose = Rigid3::Identity();
  pose.linear() = (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = position_mm;
  return pose;
}

double TangentialLoadRamp::LoadAt(double t_s) const {
  return t_s <= start_s ? 0.0 : std::min(final_load, rate_per_s * (t_s - start_s));
}

Eigen::Vector2d TangentialLoadRamp::Direction() const {
  const double a = DegToRad(direction_deg);
  return {std::cos(a), std::sin(a)};
}

Rigid3 Trajectory::PoseAt(double t_s) const {
  TAC3D_DEMAND(!keyframes.empty());
  if (t_s <= keyframes.front().t_s) return keyframes.front().world_from_sensor;
  if (t_s >= keyframes.back().t_s) return keyframes.back().world_from_sensor;
  const auto next = std::upper_bound(keyframes.begin(), keyframes.end(), t_s,
                                     [](double t, const Keyframe& k) { return t < k.t_s; });
  const Keyframe& b = *next;
  const Keyframe& a = *(next - 1);
  return InterpolatePose(a.world_from_sensor, b.world_from_sensor, (t_s - a.t_s) / (b.t_s - a.t_s));
}

double Trajectory::StepTime(int k) const {
  return keyframes.front().t_s + duration_s() * k / std::max(steps - 1, 1);
}

std::vector<Trajectory::Keyframe> ReadTrajectoryCsv(const std::string& path) {
  std::istringstream in(ReadFileCapped(path, kMaxConfigFileBytes, "trajectory CSV"));
  std::vector<Trajectory::Keyframe> keyframes;
  std::string line;
  int line_number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::string compact;
    std::remove_copy_if(line.begin(), line.end(), std::back_inserter(compact), ::isspace);
    if (!header) {
      if (compact != "t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg") {
        throw Error(fmt::format("{}:{}: the header must be t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg",
                                path, line_number));
      }
      header = true;
      continue;
    }
    std::stringstream fields(compact);
    std::string field;
    double v[7];
    int n = 0;
    while (std::getline(fields, field, ',')) {
      char* end = nullptr;
      const double value = std::strtod(field.c_str(), &end);
      if (n >= 7 || field.empty() || *end != '\0' || !std::isfinite(value)) {
        throw Error(fmt::format("{}:{}: expected 7 finite numbers", path, line_number));
      }
      v[n++] = value;
    }
    if (n != 7) throw Error(fmt::format("{}:{}: expected 7 finite numbers, got {}", path, line_number, n));
    if (!keyframes.empty() && !(v[0] > keyframes.back().t_s)) {
      throw Error(fmt::format("{}:{}: t_s = {} does not increase", path, line_number, v[0]));
    }
    keyframes.push_back({v[0], PoseFromRpy({v[1], v[2], v[3]}, {v[4], v[5], v[6]})});
  }
  if (!header) throw Error(fmt::format("trajectory CSV '{}' is empty", path));
  return keyframes;
}

// ---- Scene -------------------------------------------------------------------------------

void Scene::Validate() const {
  sensor.Validate();
  Require(deviation.mesh_refinement >= 1 && deviation.mesh_refinement <= 4, "deviation.mesh_refinement",
          "in [1, 4]", deviation.mesh_refinement);
  Require(deviation.youngs_modulus_factor >= TwinDeviation::kMinYoungsModulusFactor &&
              deviation.youngs_modulus_factor <= TwinDeviation::kMaxYoungsModulusFactor,
          "deviation.youngs_modulus_factor",
          fmt::format("in [{}, {}]", TwinDeviation::kMinYoungsModulusFactor, TwinDeviation::kMaxYoungsModulusFactor),
          deviation.youngs_modulus_factor);
  const double nu = sensor.elastic_body.poisson_ratio * deviation.poisson_ratio_factor;
  Require(deviation.poisson_ratio_factor > 0 && nu < 0.5, "deviation.poisson_ratio_factor",
          "> 0 with the twin's nu below 0.5", deviation.poisson_ratio_factor);
  conditions.Validate();
  if (spread) spread->Validate();
  if (objects.empty()) throw Error("scene: objects: a scene needs at least one object");
  for (size_t i = 0; i < objects.size(); ++i) {
    const SceneObject& o = objects[i];
    const std::string f = fmt::format("objects[{}] ({} '{}')", i, ToString(o.shape), o.name);
    switch (o.shape) {
      case SceneObject::Shape::kCylinder:
        Require(o.length_mm > 0, f + ".length_mm", "> 0", o.length_mm);
        [[fallthrough]];
      case SceneObject::Shape::kSphere:
        Require(o.radius_mm > 0, f + ".radius_mm", "> 0", o.radius_mm);
        break;
      case SceneObject::Shape::kFlatPunch:
        Require(o.radius_mm > 0, f + ".radius_mm", "> 0", o.radius_mm);
        Require(o.edge_radius_mm >= 0 && o.edge_radius_mm <= o.radius_mm, f + ".edge_radius_mm",
                "in [0, radius_mm]", o.edge_radius_mm);
        break;
      case SceneObject::Shape::kPins:
        Require(o.radius_mm > 0, f + ".radius_mm", "> 0", o.radius_mm);
        Require(o.rows >= 1 && o.rows <= 100, f + ".rows", "in [1, 100]", o.rows);
        Require(o.cols >= 1 && o.cols <= 100, f + ".cols", "in [1, 100]", o.cols);
        Require(o.pitch_mm > 2 * o.radius_mm, f + ".pitch_mm", "> 2 radius_mm (pins apart)", o.pitch_mm);
        break;
      case SceneObject::Shape::kBox:
        Require(o.size_mm.minCoeff() > 0, f + ".size_mm", "> 0 on every axis", o.size_mm.minCoeff());
        break;
      case SceneObject::Shape::kMesh:
        if (!o.mesh || o.mesh->mesh().triangles.empty()) {
          throw Error(fmt::format("scene: {}: the mesh '{}' has no triangles", f, o.ply_path));
        }
        break;
    }
    Require(o.friction.default_mu >= 0 && o.friction.default_mu <= 5, f + ".friction.default", "in [0, 5]",
            o.friction.default_mu);
    for (size_t k = 0; k < o.friction.regions.size(); ++k) {
      const FrictionRegion& r = o.friction.regions[k];
      const std::string rf = fmt::format("{}.friction.regions[{}]", f, k);
      Require(r.mu >= 0 && r.mu <= 5, rf + ".mu", "in [0, 5]", r.mu);
      if (r.kind == FrictionRegion::Kind::kBall) {
        Require(r.radius_mm > 0, rf + ".ball_radius_mm", "> 0", r.radius_mm);
      } else {
        Require((r.max_mm - r.min_mm).minCoeff() > 0, rf + ".box_max_mm", "> box_min_mm on every axis",
                (r.max_mm - r.min_mm).minCoeff());
      }
    }
    if (!o.friction.vertex_property.empty()) {
      if (!o.mesh) throw Error(fmt::format("scene: {}.friction.vertex_property: only a mesh has vertices", f));
      const auto& props = o.mesh->mesh().vertex_properties;
      const auto it = props.find(o.friction.vertex_property);
      if (it == props.end()) {
        throw Error(fmt::format("scene: {}.friction.vertex_property: the PLY has no vertex property '{}'", f,
                                o.friction.vertex_property));
      }
      for (double mu : it->second) Require(mu >= 0 && mu <= 5, f + ".friction (a vertex's mu)", "in [0, 5]", mu);
    }
  }
  const Trajectory& t = trajectory;
  Require(t.steps >= 2 && t.steps <= 1000000, "trajectory.steps", "in [2, 1000000]", t.steps);
  Require(t.keyframes.size() >= 2, "trajectory.keyframes (count)", ">= 2", t.keyframes.size());
  for (size_t k = 1; k < t.keyframes.size(); ++k) {
    Require(t.keyframes[k].t_s > t.keyframes[k - 1].t_s, fmt::format("trajectory.keyframes[{}].t_s", k),
            "greater than the previous keyframe's", t.keyframes[k].t_s);
  }
  if (const auto& load = t.tangential_load) {
    Require(load->start_s >= t.keyframes.front().t_s && load->start_s < t.keyframes.back().t_s,
            "trajectory.tangential_load.start_s", "within the keyframes' span, before the last",
            load->start_s);
    Require(load->rate_per_s > 0 && load->rate_per_s <= 1e6, "trajectory.tangential_load.rate_per_s",
            "in (0, 1e6]", load->rate_per_s);
    Require(load->final_load > 0 && load->final_load <= 10, "trajectory.tangential_load.final_load",
            "in (0, 10]", load->final_load);
    Require(std::abs(load->direction_deg) <= 360, "trajectory.tangential_load.direction_deg",
            "in [-360, 360]", load->direction_deg);
    // Under the load the pose only presses: the load moves the object tangentially.
    const Rigid3 loaded = t.PoseAt(load->start_s);
    for (size_t k = 0; k < t.keyframes.size(); ++k) {
      if (t.keyframes[k].t_s <= load->start_s) continue;
      const Rigid3& pose = t.keyframes[k].world_from_sensor;
      const double moved = (pose.translation() - loaded.translation()).head<2>().norm();
      const double turned = Eigen::AngleAxisd(pose.linear() * loaded.linear().transpose()).angle();
      Require(moved < 1e-9 && turned < 1e-9, fmt::format("trajectory.keyframes[{}] (x-y motion, mm, and turn, rad, under "
              "tangential_load)", k), "0", moved + turned);
    }
  }
}

namespace {

// The `conditions:` section: `levels` (none | realistic) to start from, then any level.
SessionConditions ReadConditions(YamlReader r) {
  const std::string levels = r.String("levels", "none");
  if (levels != "none" && levels != "realistic") r.Fail(r.Join("levels"), "must be none or realistic");
  SessionConditions c = levels == "realistic" ? SessionConditions::Realistic() : SessionConditions{};
  c.session_s = r.Double("session_s", c.session_s);
  c.illumination_gain = r.Double("illumination_gain", c.illumination_gain);
  c.illumination_offset = r.Double("illumination_offset", c.illumination_offset);
  c.illumination_gradient = r.Double("illumination_gradient", c.illumination_gradient);
  c.contrast_fade = r.Double("contrast_fade", c.contrast_fade);
  c.exposure_drift = r.Double("exposure_drift", c.exposure_drift);
  c.creep_mm = r.Double("creep_mm", c.creep_mm);
  c.creep_direction = r.Vector<3>("creep_direction", c.creep_direction);
  return c;
}

// The `spread:` section: ManufacturingSpread's tolerances unless given.
SensorPerturbationOptions ReadSpread(YamlReader r) {
  SensorPerturbationOptions o = SensorPerturbationOptions::ManufacturingSpread(r.Int("seed", 1));
  o.mirror_tilt_max_deg = r.Double("mirror_tilt_max_deg", o.mirror_tilt_max_deg);
  o.mirror_shift_max_mm = r.Double("mirror_shift_max_mm", o.mirror_shift_max_mm);
  o.camera_tilt_max_deg = r.Double("camera_tilt_max_deg", o.camera_tilt_max_deg);
  o.camera_shift_max_mm = r.Double("camera_shift_max_mm", o.camera_shift_max_mm);
  return o;
}

}  // namespace

Scene ParseScene(const std::string& yaml_text, const std::string& source, const std::string& base_dir) {
  const YAML::Node root = ParseYamlDocument(yaml_text, source);
  Scene scene;
  {
    YamlReader r(root, "", &source);
    scene.name = r.String("name");
    const std::string sensor = r.String("sensor", "default");
    scene.sensor = sensor == "default" ? DefaultSensorConfig() : LoadSensorConfig(Resolve(base_dir, sensor));
    if (r.Has("deviation")) {
      YamlReader d = r.Child("deviation");
      scene.deviation.mesh_refinement = d.Double("mesh_refinement", scene.deviation.mesh_refinement);
      scene.deviation.youngs_modulus_factor = d.Double("youngs_modulus_factor", scene.deviation.youngs_modulus_factor);
      scene.deviation.poisson_ratio_factor = d.Double("poisson_ratio_factor", scene.deviation.poisson_ratio_factor);
    }
    if (r.Has("conditions")) scene.conditions = ReadConditions(r.Child("conditions"));
    if (r.Has("spread")) scene.spread = ReadSpread(r.Child("spread"));
    const YAML::Node objects = r.Sequence("objects");
    for (size_t i = 0; i < objects.size(); ++i) {
      scene.objects.push_back(ReadObject(r.Element(objects, "objects", i), base_dir));
    }
    scene.trajectory = ReadTrajectory(r.Child("trajectory"), base_dir);
  }
  scene.Validate();
  return scene;
}

Scene LoadScene(const std::string& path) {
  return ParseScene(ReadFileCapped(path, kMaxConfigFileBytes, "scene file"), path,
                    fs::path(path).parent_path().string());
}

Scene LoadSceneOrBuiltIn(const std::string& path_or_name) {
  const auto names = BuiltInSceneNames();
  if (std::find(names.begin(), names.end(), path_or_name) != names.end()) return BuiltInScene(path_or_name);
  if (!fs::exists(path_or_name) && ParseIncipientSceneName(path_or_name)) return BuiltInScene(path_or_name);
  if (!fs::exists(path_or_name)) {
    throw Error(fmt::format("scene '{}': no such file, and not a built-in scene ({})", path_or_name,
                            fmt::join(names, ", ")));
  }
  return LoadScene(path_or_name);
}

}  // namespace tac3d
