#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/friction/friction_map.h"

namespace tac3d {

struct Scene;
struct SceneObject;
struct TwinStep;
class TwinDatasetReader;

/// How a friction map is compared with a twin scene's truth.
struct FrictionEvaluationOptions {
  /// A touched point of the true surface is covered when a mesh vertex with a known mu lies
  /// within this distance of it (mm, > 0). The marker pitch is 1.27 mm; Poisson's vertices
  /// at depth 8 are ~0.2 mm apart.
  double coverage_distance_mm = 0.5;
  /// The touched true surface (the twin's surface nodes in contact at some step, mapped to the
  /// world and projected onto the object) is deduplicated on voxels of this edge (mm, > 0).
  double touched_voxel_mm = 0.25;
  /// The slip truth's force floor (N, >= 0). The twin marks a marker slipping when a cell of
  /// its 3 x 3 patch slips (TwinStep::marker_slip), however lightly it is pressed: at the
  /// contact's edge a marker whose patch carries a few mN is "slipping". A force-based contact
  /// test cannot tell such a marker from one out of contact: the per-marker 1-sigma noise of
  /// the normal force is about 0.006 N (docs/force.md), and the contact threshold is 0.02 N,
  /// 3 sigma. So a true slip is a slipping marker whose true normal force exceeds this floor;
  /// slipping markers pressed less are counted apart (light slips: neither a miss when not
  /// found nor a false slip point when found), and slip_recall_any_cell counts them all.
  double slip_truth_min_force_n = 0.02;
  /// @throws Error naming the field and its bound.
  void Validate() const;
};

/// The nearest point of an object's true surface (analytic, or a mesh's triangles) to a
/// world point.
struct SurfacePoint {
  Eigen::Vector3d p_in_world_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_in_object_mm = Eigen::Vector3d::Zero();
  double distance_mm = 0.0;
  int object = -1;  ///< index in Scene::objects
};

/// The nearest point on the surface of the scene's objects (sphere, cylinder's lateral
/// surface, box, mesh: its triangles with an area, IndexedMesh::ClosestSurfacePoint).
/// @throws Error if an object has another shape (punch, pins) or is a mesh with no triangle
///   of non-zero area.
SurfacePoint NearestSurfacePoint(const Scene& scene, const Eigen::Vector3d& p_in_world_mm);

/// Feeds replayed frames to a FrictionMapBuilder at the twin's world_from_sensor and keeps
/// the twin's per-marker slip truth for the slip points. A frame with no marker in contact
/// (by the builder's threshold) ends a stroke (BreakStroke): the sensor was lifted.
class FrictionReplayRecorder {
 public:
  explicit FrictionReplayRecorder(friction::FrictionMapBuilder& builder) : builder_(builder) {}
  void Add(const TwinStep& step, const TactileFrame& frame);

  /// Per frame index: the twin's marker_slip, and whether the frame followed another one
  /// of the same stroke (only then can a slip be detected).
  struct FrameTruth {
    std::vector<std::uint8_t> marker_slip;
    /// The measured frame's contact markers (valid, F_n over the builder's threshold).
    std::vector<std::uint8_t> measured_contact;
    /// The twin's per-marker normal force (N).
    std::vector<double> true_normal_force_n;
    bool has_previous = false;
  };
  const std::map<std::int64_t, FrameTruth>& truth() const { return truth_; }
  int strokes() const { return strokes_; }

 private:
  friction::FrictionMapBuilder& builder_;
  std::map<std::int64_t, FrameTruth> truth_;
  bool previous_ = false;
  int strokes_ = 0;
};

/// The true surface the fingertip touched: every twin surface node in contact (stick or
/// slip) at some step, mapped to the world by the step's pose and projected onto the
/// scene's objects, deduplicated on voxels of `voxel_mm`. Reads every step's tractions.
/// @param max_steps only the first N steps (0: all).
std::vector<Eigen::Vector3d> TouchedTrueSurface(const TwinDatasetReader& dataset,
                                                const Scene& scene,
                                                double voxel_mm,
                                                int max_steps = 0);

/// A friction map against the truth. Every "area-weighted" figure weighs a mesh vertex by a
/// third of the area of its triangles. Fields start at "not run" values (NaN, 0).
struct FrictionEvaluation {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::string scene;
  // ---- The figures ----
  /// Area-weighted mean |mu - true mu| over vertices with a known mu; true mu is the scene's
  /// FrictionAt the vertex's nearest true surface point.
  double mu_mae = kNaN;
  /// Area fraction of the vertices with a known mu whose band (blue <= 0.5 < green <= 0.8
  /// < red) is the true one.
  double band_agreement = kNaN;
  /// Mean distance from the estimated contours (mu = the midpoint of two materials that meet
  /// on the surface, crossed on mesh edges with both ends known) to the true boundary between
  /// them (located by bisection on the true surface); NaN if no two materials meet.
  double boundary_error_mm = kNaN;
  double boundary_error_median_mm = kNaN;
  double boundary_error_p90_mm = kNaN;
  double boundary_error_max_mm = kNaN;
  /// Fraction of the touched true surface (TouchedTrueSurface) with a known-mu vertex within
  /// coverage_distance_mm.
  double coverage = kNaN;
  /// Area-weighted RMS and max distance of every mesh vertex to the true surface.
  double surface_rms_mm = kNaN;
  double surface_max_mm = kNaN;
  /// Slip points at true slips / slip points not at light slips (see
  /// FrictionEvaluationOptions::slip_truth_min_force_n), and true slips (at frames that
  /// followed another frame of their stroke) found as slip points.
  double slip_precision = kNaN;
  double slip_recall = kNaN;
  /// The recall over every marker the twin marks slipping, light slips too.
  double slip_recall_any_cell = kNaN;
  // ---- Counts and sums (so scenes pool into an overall figure) ----
  long vertices = 0;
  long known_vertices = 0;
  double area_mm2 = 0.0;
  double known_area_mm2 = 0.0;
  double mu_abs_error_area = 0.0;  ///< sum of area x |mu error| over known vertices
  double band_agree_area = 0.0;
  double surface_sq_area = 0.0;  ///< sum of area x distance^2
  std::vector<double> boundary_distances_mm;
  std::vector<double> boundary_levels;  ///< the contour levels (material midpoints)
  long touched_points = 0;
  long covered_points = 0;
  long slip_points = 0;
  long slip_points_at_light_slips = 0;
  long slip_true_positives = 0;
  long true_slips = 0;
  long true_slips_found = 0;
  /// Missed true slips whose marker was not in measured contact in the frame or the one
  /// before (the rest moved less than the slip threshold).
  long true_slips_missed_no_contact = 0;
  long light_slips = 0;
  long light_slips_found = 0;
  double slip_truth_min_force_n = 0.0;
  /// The builder's summary for the map.
  friction::FrictionMapSummary map;
  // ---- Times (s) ----
  double simulate_s = 0.0;
  double replay_s = 0.0;
  double map_s = 0.0;
  double evaluate_s = 0.0;

  /// One line: the figures.
  std::string BriefReport() const;
};

/// The acceptance targets of the friction-map evaluation.
struct FrictionTargets {
  double mu_mae = 0.05;
  double band_agreement = 0.90;
  double boundary_error_mm = 1.27;
  double coverage = 0.8;
  double surface_rms_mm = 0.1;
  double slip_precision = 0.97;
  double slip_recall = 0.97;
};

/// Compares the map with the scene's truth.
/// @param truth the recorder's per-frame slip truth; @param touched TouchedTrueSurface.
/// @throws Error as NearestSurfacePoint.
FrictionEvaluation EvaluateFrictionMap(
    const Scene& scene,
    const friction::FrictionMapResult& map,
    const std::map<std::int64_t, FrictionReplayRecorder::FrameTruth>& truth,
    const std::vector<Eigen::Vector3d>& touched,
    const FrictionEvaluationOptions& options = {});

/// The scenes pooled: sums and counts added, figures recomputed from them (area-weighted
/// over all scenes' vertices, contour points, touched points and slip points).
FrictionEvaluation PoolFrictionEvaluations(const std::vector<FrictionEvaluation>& scenes);

/// Figures, counts, the map's summary and times, and `checks` against the targets
/// ([{name, value, unit, tolerance, pass}], as the other evaluations) with `all_pass`.
nlohmann::json ToJson(const FrictionEvaluation& evaluation, const FrictionTargets& targets = {});

}  // namespace tac3d
