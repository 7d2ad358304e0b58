#include "tac3d/friction/friction_map.h"

#include <fmt/format.h>
#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <thread>
#include <unordered_map>

#include "tac3d/util/error.h"
#include "tac3d/util/json_number.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::friction {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The largest pose coordinate (mm): 1 km. Far beyond any scan, and small enough that the
// resampling's voxel indices and the reconstruction's octree stay finite and in range
// (a pose of 1e300 mm crashed the reconstruction).
constexpr double kMaxWorldCoordinateMm = 1e6;

using Clock = std::chrono::steady_clock;

void Require(bool ok, const char* field, const char* bound, double value) {
  if (!ok || std::isnan(value)) {
    throw Error(
        fmt::format("FrictionMapOptions.{} = {} is out of range: must be {}", field, value, bound));
  }
}

// Open3D's Poisson with more threads than cores crashed (SIGSEGV with 3 on 2 cores): at most
// one a core.
int ReconstructionThreads(int requested) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  return requested == 0 ? cores : std::min(requested, cores);
}

// The cloud resampled on voxels (points and normals averaged, normals renormalised).
std::shared_ptr<open3d::geometry::PointCloud> Resample(const std::vector<Eigen::Vector3d>& points,
                                                       const std::vector<Eigen::Vector3d>& normals,
                                                       double voxel_size_mm) {
  open3d::geometry::PointCloud cloud;
  cloud.points_ = points;
  cloud.normals_ = normals;
  auto resampled = cloud.VoxelDownSample(voxel_size_mm);
  resampled->NormalizeNormals();
  return resampled;
}

// Drops the vertices farther than trim_distance_mm from every point of the cloud (with the
// triangles that use them) and the vertices no triangle uses.
void Trim(const open3d::geometry::PointCloud& cloud,
          double trim_distance_mm,
          open3d::geometry::TriangleMesh& mesh) {
  const open3d::geometry::KDTreeFlann tree(cloud);
  std::vector<bool> remove(mesh.vertices_.size(), false);
  std::vector<int> index(1);
  std::vector<double> distance2(1);
  const double limit2 = trim_distance_mm * trim_distance_mm;
  for (size_t v = 0; v < mesh.vertices_.size(); ++v) {
    remove[v] = tree.SearchKNN(mesh.vertices_[v], 1, index, distance2) < 1 || distance2[0] > limit2;
  }
  mesh.RemoveVerticesByMask(remove);
  mesh.RemoveUnreferencedVertices();
}

// mu, confidence and slip count at every vertex (equations 5 and 6).
void AssignFriction(const std::vector<SlipPoint>& slips,
                    const FrictionMapOptions& options,
                    FrictionMapResult& result) {
  const size_t n = result.vertices_mm.size();
  result.mu.assign(n, kNaN);
  result.confidence.assign(n, 0.0);
  result.slip_count.assign(n, 0);
  if (slips.empty()) return;
  // Only slip points pressed beyond the surface's contact threshold vote: those found with a
  // lower slip_contact_threshold_n count as slips but their forces are too uncertain for mu.
  std::vector<const SlipPoint*> voters;
  for (const SlipPoint& s : slips) {
    if (s.normal_force_n > options.contact_threshold_n &&
        (!options.gross_slip_only || s.gross_slip))
      voters.push_back(&s);
  }
  result.summary.voting_slip_points = static_cast<long>(voters.size());
  if (voters.empty()) return;
  open3d::geometry::PointCloud cloud;
  cloud.points_.reserve(voters.size());
  for (const SlipPoint* s : voters) cloud.points_.push_back(s->p_in_world_mm);
  const open3d::geometry::KDTreeFlann tree(cloud);
  std::vector<int> index;
  std::vector<double> distance2, mu_i, r_i, fn_i;
  const double max_offset = options.max_support_offset * options.radius_mm;
  for (size_t v = 0; v < n; ++v) {
    const Eigen::Vector3d& vertex = result.vertices_mm[v];
    const int found = tree.SearchRadius(vertex, options.radius_mm, index, distance2);
    if (found <= 0) continue;
    result.slip_count[v] = found;
    if (found < options.min_slip_points) continue;
    mu_i.resize(found);
    r_i.resize(found);
    fn_i.resize(found);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    double weight = 0.0;
    for (int k = 0; k < found; ++k) {
      const SlipPoint& s = *voters[index[k]];
      mu_i[k] = s.mu;
      r_i[k] = std::sqrt(distance2[k]);
      fn_i[k] = s.normal_force_n;
      const double w = SupportWeight(r_i[k], fn_i[k], options);
      centre += w * s.p_in_world_mm;
      weight += w;
    }
    if (options.max_support_offset < 1.0 && weight > 0 &&
        (centre / weight - vertex).norm() > max_offset)
      continue;
    result.mu[v] = WeightedFriction(mu_i, r_i, options, &result.confidence[v], fn_i);
  }
}

void SummariseFriction(FrictionMapResult& result) {
  FrictionMapSummary& s = result.summary;
  std::vector<double> known;
  for (double mu : result.mu) {
    if (!std::isnan(mu)) known.push_back(mu);
  }
  s.vertices = static_cast<long>(result.vertices_mm.size());
  s.triangles = static_cast<long>(result.triangles.size());
  s.unknown_vertices = s.vertices - static_cast<long>(known.size());
  s.unknown_fraction = s.vertices > 0 ? static_cast<double>(s.unknown_vertices) / s.vertices : kNaN;
  if (!known.empty()) {
    std::sort(known.begin(), known.end());
    s.mu_min = known.front();
    s.mu_max = known.back();
    s.mu_median = known[known.size() / 2];
  }
}

}  // namespace

// ---- Options -----------------------------------------------------------------------------

FrictionMapOptions FrictionMapOptions::WithSensor(const SensorConfig& sensor) const {
  FrictionMapOptions options = *this;
  options.cover_thickness_mm = sensor.markers.depth_mm;
  return options;
}

double FrictionMapOptions::SlipThresholdMm() const {
  return slip_sigmas *
         std::sqrt(2.0 * (marker_noise_mm * marker_noise_mm + pose_noise_mm * pose_noise_mm));
}

void FrictionMapOptions::Validate() const {
  Require(contact_threshold_n >= 0 && std::isfinite(contact_threshold_n),
          "contact_threshold_n",
          ">= 0 and finite",
          contact_threshold_n);
  Require(cover_thickness_mm >= 0 && cover_thickness_mm <= 5,
          "cover_thickness_mm",
          "in [0, 5]",
          cover_thickness_mm);
  Require(marker_noise_mm > 0 && std::isfinite(marker_noise_mm),
          "marker_noise_mm",
          "> 0 and finite",
          marker_noise_mm);
  Require(pose_noise_mm >= 0 && std::isfinite(pose_noise_mm),
          "pose_noise_mm",
          ">= 0 and finite",
          pose_noise_mm);
  Require(
      slip_sigmas > 0 && std::isfinite(slip_sigmas), "slip_sigmas", "> 0 and finite", slip_sigmas);
  Require(voxel_size_mm > 0 && std::isfinite(voxel_size_mm),
          "voxel_size_mm",
          "> 0 and finite",
          voxel_size_mm);
  Require(poisson_depth >= 4 && poisson_depth <= 12, "poisson_depth", "in [4, 12]", poisson_depth);
  Require(poisson_scale >= 1 && poisson_scale <= 2, "poisson_scale", "in [1, 2]", poisson_scale);
  Require(num_threads >= 0 && num_threads <= kMaxThreads,
          "num_threads",
          fmt::format("in [0, {}] (0: one a core)", kMaxThreads).c_str(),
          num_threads);
  Require(trim_distance_mm > 0 && std::isfinite(trim_distance_mm),
          "trim_distance_mm",
          "> 0 and finite",
          trim_distance_mm);
  Require(radius_mm > 0 && std::isfinite(radius_mm), "radius_mm", "> 0 and finite", radius_mm);
  Require(alpha >= 0 && std::isfinite(alpha), "alpha", ">= 0 and finite", alpha);
  Require(beta >= 0 && std::isfinite(beta), "beta", ">= 0 and finite", beta);
  Require(slip_contact_threshold_n < 0 || std::isfinite(slip_contact_threshold_n),
          "slip_contact_threshold_n",
          "finite (< 0: contact_threshold_n)",
          slip_contact_threshold_n);
  Require(gross_slip_margin >= 0, "gross_slip_margin", ">= 0", gross_slip_margin);
  Require(min_slip_points >= 1, "min_slip_points", ">= 1", min_slip_points);
  Require(max_support_offset > 0 && max_support_offset <= 1,
          "max_support_offset",
          "in (0, 1]",
          max_support_offset);
  Require(normal_force_exponent >= 0 && std::isfinite(normal_force_exponent),
          "normal_force_exponent",
          ">= 0 and finite",
          normal_force_exponent);
}

// ---- Summary -----------------------------------------------------------------------------

std::string ToString(FrictionMapStatus status) {
  switch (status) {
    case FrictionMapStatus::kNotRun:
      return "not_run";
    case FrictionMapStatus::kOk:
      return "ok";
    case FrictionMapStatus::kNoContact:
      return "no_contact";
    case FrictionMapStatus::kTooFewPoints:
      return "too_few_points";
    case FrictionMapStatus::kReconstructionFailed:
      return "reconstruction_failed";
    case FrictionMapStatus::kNoSlip:
      return "no_slip";
  }
  return "unknown";
}

std::string FrictionMapSummary::BriefReport() const {
  return fmt::format(
      "friction map {}: {} frames ({} skipped), {} contact points -> {} resampled, {} slip points "
      "of {} "
      "pairs (threshold {:.4f} mm, noise est. {:.4f} mm), mesh {} vertices {} triangles, unknown "
      "{:.1f}%, "
      "mu median {:.3f}, Poisson {:.2f} s, total {:.2f} s{}{}",
      ToString(status),
      frames,
      frames_skipped,
      contact_points,
      resampled_points,
      slip_points,
      marker_pairs,
      slip_threshold_mm,
      estimated_noise_mm,
      vertices,
      triangles,
      100.0 * unknown_fraction,
      mu_median,
      poisson_time_s,
      total_time_s,
      message.empty() ? "" : ": ",
      message);
}

nlohmann::json ToJson(const FrictionMapOptions& o) {
  return {{"contact_threshold_n", o.contact_threshold_n},
          {"slip_contact_threshold_n", o.SlipContactThresholdN()},
          {"cover_thickness_mm", o.cover_thickness_mm},
          {"marker_noise_mm", o.marker_noise_mm},
          {"pose_noise_mm", o.pose_noise_mm},
          {"slip_sigmas", o.slip_sigmas},
          {"slip_threshold_mm", o.SlipThresholdMm()},
          {"tangential_motion", o.tangential_motion},
          {"gross_slip_only", o.gross_slip_only},
          {"friction_along_slip", o.friction_along_slip},
          {"gross_slip_margin", o.gross_slip_margin},
          {"voxel_size_mm", o.voxel_size_mm},
          {"poisson_depth", o.poisson_depth},
          {"trim_distance_mm", o.trim_distance_mm},
          {"radius_mm", o.radius_mm},
          {"alpha", o.alpha},
          {"beta", o.beta},
          {"gamma", o.normal_force_exponent},
          {"min_slip_points", o.min_slip_points},
          {"max_support_offset", o.max_support_offset}};
}

nlohmann::json ToJson(const FrictionMapSummary& s) {
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"frames", s.frames},
          {"frames_skipped", s.frames_skipped},
          {"contact_points", s.contact_points},
          {"marker_pairs", s.marker_pairs},
          {"slip_points", s.slip_points},
          {"gross_slip_frames", s.gross_slip_frames},
          {"voting_slip_points", s.voting_slip_points},
          {"slip_threshold_mm", s.slip_threshold_mm},
          {"estimated_noise_mm", FiniteOrNull(s.estimated_noise_mm)},
          {"resampled_points", s.resampled_points},
          {"poisson_vertices", s.poisson_vertices},
          {"vertices", s.vertices},
          {"triangles", s.triangles},
          {"unknown_vertices", s.unknown_vertices},
          {"unknown_fraction", FiniteOrNull(s.unknown_fraction)},
          {"mu_min", FiniteOrNull(s.mu_min)},
          {"mu_median", FiniteOrNull(s.mu_median)},
          {"mu_max", FiniteOrNull(s.mu_max)},
          {"resample_time_s", s.resample_time_s},
          {"poisson_time_s", s.poisson_time_s},
          {"trim_time_s", s.trim_time_s},
          {"mu_time_s", s.mu_time_s},
          {"total_time_s", s.total_time_s}};
}

// ---- Equations 5 and 6 -------------------------------------------------------------------

double SupportWeight(double distance_mm, double normal_force_n, const FrictionMapOptions& options) {
  double w = std::pow(std::max(options.radius_mm - distance_mm, 0.0), options.alpha);
  if (normal_force_n >= 0 && options.normal_force_exponent != 0.0)
    w *= std::pow(normal_force_n, options.normal_force_exponent);
  return w;
}

double WeightedFriction(const std::vector<double>& mu_i,
                        const std::vector<double>& distance_mm,
                        const FrictionMapOptions& options,
                        double* weight_sum,
                        const std::vector<double>& normal_force_n) {
  TAC3D_DEMAND(mu_i.size() == distance_mm.size());
  TAC3D_DEMAND(normal_force_n.empty() || normal_force_n.size() == mu_i.size());
  double sum_w = 0.0, sum_w_mu = 0.0, sum_mu = 0.0;
  for (size_t i = 0; i < mu_i.size(); ++i) {
    // Clamped to 0: a negative F_n must not read as "no force factor".
    const double fn = normal_force_n.empty() ? -1.0 : std::max(normal_force_n[i], 0.0);
    const double w = SupportWeight(distance_mm[i], fn, options) * std::pow(mu_i[i], options.beta);
    sum_w += w;
    sum_w_mu += w * mu_i[i];
    sum_mu += mu_i[i];
  }
  if (weight_sum != nullptr) *weight_sum = sum_w;
  if (mu_i.empty()) return kNaN;
  if (sum_w > 0) return sum_w_mu / sum_w;
  return sum_mu / static_cast<double>(mu_i.size());
}

// ---- Builder -----------------------------------------------------------------------------

FrictionMapBuilder::FrictionMapBuilder(const FrictionMapOptions& options) : options_(options) {
  options_.Validate();
}

void FrictionMapBuilder::BreakStroke() {
  previous_world_mm_.clear();
  previous_sensor_mm_.clear();
  previous_contact_.clear();
}

void FrictionMapBuilder::AddFrameOfStrokes(const TactileFrame& frame,
                                           const Rigid3& world_from_sensor) {
  AddFrame(frame, world_from_sensor);
  for (size_t i = 0; i < frame.forces_n.size(); ++i) {
    if (frame.valid[i] && -frame.forces_n[i].dot(frame.normals[i]) > options_.contact_threshold_n)
      return;
  }
  BreakStroke();
}

void FrictionMapBuilder::AddFrame(const TactileFrame& frame, const Rigid3& world_from_sensor) {
  frame.Validate();
  const Eigen::Matrix3d r = world_from_sensor.linear();
  if (!world_from_sensor.matrix().allFinite() || !(r.transpose() * r).isIdentity(1e-6) ||
      !(r.determinant() > 0)) {
    throw Error(fmt::format("frame {} (t = {} s): world_from_sensor is not a rigid transform",
                            frame.index,
                            frame.timestamp_s));
  }
  if (!(world_from_sensor.translation().cwiseAbs().maxCoeff() <= kMaxWorldCoordinateMm)) {
    throw Error(fmt::format("frame {} (t = {} s): world_from_sensor's translation {} mm is over the "
                            "{} mm a friction map spans (a pose in other units?)",
                            frame.index,
                            frame.timestamp_s,
                            world_from_sensor.translation().cwiseAbs().maxCoeff(),
                            kMaxWorldCoordinateMm));
  }
  if (frame.initialize_progress < 100) {
    ++frames_skipped_;
    BreakStroke();
    return;
  }
  ++frames_;
  const int n = frame.num_markers();
  const bool has_previous = static_cast<int>(previous_contact_.size()) == n;
  if (!has_previous) ++stroke_;
  // Gross slip: every pressed pair slid on the object and the contact's deformation is steady
  // (its marker positions in the sensor frame did not change beyond the noise).
  const double steady_threshold = options_.slip_sigmas * std::sqrt(2.0) * options_.marker_noise_mm;
  int loaded_pairs = 0, loaded_stuck = 0, loaded_unsteady = 0;
  const double threshold = options_.SlipThresholdMm();
  const double slip_contact = options_.SlipContactThresholdN();
  // This frame's markers, in buffers reused from frame to frame.
  std::vector<Eigen::Vector3d>& world_mm = current_world_mm_;
  std::vector<bool>& contact = current_contact_;
  world_mm.assign(n, Eigen::Vector3d::Zero());
  contact.assign(n, false);
  for (int i = 0; i < n; ++i) {
    if (!frame.valid[i]) continue;
    const Eigen::Vector3d& normal = frame.normals[i];
    const Eigen::Vector3d& f = frame.forces_n[i];
    const double normal_force = -f.dot(normal);
    world_mm[i] = world_from_sensor * frame.positions_mm[i];
    const bool surface_contact = normal_force > options_.contact_threshold_n;
    contact[i] = normal_force > slip_contact;
    if (!surface_contact && !contact[i]) continue;
    const Eigen::Vector3d surface =
        world_from_sensor * (frame.positions_mm[i] + options_.cover_thickness_mm * normal);
    if (surface_contact) {
      surface_points_.push_back(surface);
      surface_normals_.push_back(-(r * normal));
    }
    if (!contact[i] || !has_previous || !previous_contact_[i]) continue;
    ++marker_pairs_;
    Eigen::Vector3d moved = world_mm[i] - previous_world_mm_[i];
    if (options_.tangential_motion) {
      const Eigen::Vector3d n_world = r * normal;
      moved -= moved.dot(n_world) * n_world;
    }
    const double motion = moved.norm();
    if (surface_contact) {
      ++loaded_pairs;
      if (motion <= threshold) ++loaded_stuck;
      Eigen::Vector3d deformed = frame.positions_mm[i] - previous_sensor_mm_[i];
      deformed -= deformed.dot(normal) * normal;
      if (deformed.norm() > steady_threshold) ++loaded_unsteady;
    }
    if (motion > threshold) {
      const Eigen::Vector3d tangential = f + normal_force * normal;
      double friction_n = tangential.norm();
      if (options_.friction_along_slip) {
        // The slip's direction: the marker's motion on the object, in the sensor frame and
        // the tangent plane.
        Eigen::Vector3d slip = r.transpose() * moved;
        slip -= slip.dot(normal) * normal;
        const double length = slip.norm();
        friction_n = length > 0 ? std::max(0.0, -tangential.dot(slip) / length) : 0.0;
      }
      slip_points_.push_back(
          {surface, friction_n / normal_force, normal_force, motion, frame.index, i});
    } else {
      stuck_sum_squared_mm2_ += motion * motion;
      ++stuck_pairs_;
    }
  }
  if (has_previous)
    frame_motion_.push_back(
        {frame.index, stroke_, loaded_pairs > 0 && loaded_stuck == 0 && loaded_unsteady == 0});
  previous_sensor_mm_ = frame.positions_mm;
  previous_world_mm_.swap(current_world_mm_);
  previous_contact_.swap(current_contact_);
}

void FrictionMapBuilder::MarkGrossSlip(std::vector<SlipPoint>& slips, int* gross_frames) const {
  // Per frame: gross slip, with gross_slip_margin frames of its stroke on either side.
  const int m = options_.gross_slip_margin;
  const int count = static_cast<int>(frame_motion_.size());
  std::unordered_map<std::int64_t, bool> steady;
  *gross_frames = 0;
  for (int k = 0; k < count; ++k) {
    const FrameMotion& f = frame_motion_[k];
    *gross_frames += f.gross_slip ? 1 : 0;
    bool ok = f.gross_slip && k - m >= 0 && k + m < count;
    for (int j = k - m; ok && j <= k + m; ++j)
      ok = frame_motion_[j].stroke == f.stroke && frame_motion_[j].gross_slip;
    steady[f.index] = ok;
  }
  for (SlipPoint& s : slips) {
    const auto it = steady.find(s.frame_index);
    s.gross_slip = it != steady.end() && it->second;
  }
}

FrictionMapResult FrictionMapBuilder::Build(const ProgressCallback& progress) const {
  const Clock::time_point start = Clock::now();
  const auto report = [&](int done) {
    if (progress) progress(done, 4);
  };
  FrictionMapResult result;
  FrictionMapSummary& s = result.summary;
  s.frames = frames_;
  s.frames_skipped = frames_skipped_;
  s.contact_points = static_cast<long>(surface_points_.size());
  s.marker_pairs = marker_pairs_;
  s.slip_points = static_cast<long>(slip_points_.size());
  s.slip_threshold_mm = options_.SlipThresholdMm();
  if (stuck_pairs_ > 0)
    s.estimated_noise_mm = std::sqrt(stuck_sum_squared_mm2_ / (6.0 * stuck_pairs_));
  result.slip_points = slip_points_;
  MarkGrossSlip(result.slip_points, &s.gross_slip_frames);
  const auto finish = [&](FrictionMapStatus status, std::string message) {
    s.status = status;
    s.message = std::move(message);
    s.total_time_s = SecondsSince(start);
    return result;
  };
  if (surface_points_.empty())
    return finish(FrictionMapStatus::kNoContact, "no marker was in contact");

  Clock::time_point t = Clock::now();
  const auto cloud = Resample(surface_points_, surface_normals_, options_.voxel_size_mm);
  s.resampled_points = static_cast<long>(cloud->points_.size());
  s.resample_time_s = SecondsSince(t);
  report(1);
  if (s.resampled_points < kMinReconstructionPoints) {
    return finish(FrictionMapStatus::kTooFewPoints,
                  fmt::format("{} resampled points, a reconstruction needs {}",
                              s.resampled_points,
                              kMinReconstructionPoints));
  }

  t = Clock::now();
  auto [mesh, densities] = open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(
      *cloud,
      options_.poisson_depth,
      0.0f,
      static_cast<float>(options_.poisson_scale),
      false,
      ReconstructionThreads(options_.num_threads));
  s.poisson_time_s = SecondsSince(t);
  s.poisson_vertices = static_cast<long>(mesh->vertices_.size());
  report(2);

  t = Clock::now();
  Trim(*cloud, options_.trim_distance_mm, *mesh);
  mesh->ComputeVertexNormals();
  s.trim_time_s = SecondsSince(t);
  report(3);
  if (mesh->vertices_.empty() || mesh->triangles_.empty()) {
    return finish(
        FrictionMapStatus::kReconstructionFailed,
        fmt::format("no vertex of the Poisson surface ({} vertices) is within {} mm of the points",
                    s.poisson_vertices,
                    options_.trim_distance_mm));
  }
  result.vertices_mm = mesh->vertices_;
  result.triangles = mesh->triangles_;
  result.vertex_normals = mesh->vertex_normals_;

  t = Clock::now();
  AssignFriction(result.slip_points, options_, result);
  SummariseFriction(result);
  s.mu_time_s = SecondsSince(t);
  report(4);
  if (slip_points_.empty())
    return finish(FrictionMapStatus::kNoSlip, "no slip point: mu is unknown everywhere");
  return finish(FrictionMapStatus::kOk, "");
}

}  // namespace tac3d::friction
