#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/geometry/geometry.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d::friction {

/// How the friction map is built from a sensor sliding over a fixed object (the paper's
/// section IV.B: contact region, surface cloud, resampling and Poisson reconstruction, slip
/// points and equations 5 and 6). Lengths in mm, forces in N. The defaults are the paper's
/// method; the commands (`tac3d friction-map`, Python's tac3d.friction_map) start from
/// CommandFrictionMapDefaults() (command_options.h), the twin evaluation's choices.
struct FrictionMapOptions {
  // ---- Contact region ----
  /// A marker is in contact where its normal force -(f . n) exceeds this (N, >= 0, finite).
  /// The default is force::ContactOptions' threshold.
  double contact_threshold_n = 0.02;
  /// Depth of the markers under the outer surface (mm, in [0, 5]): contact markers are moved
  /// this far along their outward normal so the cloud lies on the object's surface.
  /// SensorConfig::markers.depth_mm; WithSensor sets it.
  double cover_thickness_mm = 0.5;
  /// A marker counts as in contact for slip detection (a pair of adjacent frames, a slip
  /// point) where its normal force exceeds this (N); < 0: contact_threshold_n. Lower than
  /// contact_threshold_n, it finds the slips at the contact's edge, whose small forces are
  /// too uncertain to place the surface cloud (such markers are not pressed flat on the
  /// object) but still move with the sensor. Only slip points over contact_threshold_n vote
  /// for mu (equations 5 and 6): the others are slips, but their force ratio is unreliable.
  double slip_contact_threshold_n = -1.0;

  // ---- Slip points ----
  /// Per-axis standard deviation of a measured marker position (mm, > 0). The pipeline's
  /// displacement RMSE is about 0.002 mm per axis (docs/accuracy.md).
  double marker_noise_mm = 0.002;
  /// Per-axis standard deviation of a pose's error at the markers, independent from frame to
  /// frame (mm, >= 0): motion-capture jitter. 0 for a perfectly known pose.
  double pose_noise_mm = 0.0;
  /// k: a contact marker slips when its world motion between adjacent frames exceeds k times
  /// the per-axis standard deviation of the difference of two noisy positions,
  /// sqrt(2 (marker_noise^2 + pose_noise^2)) (> 0). A stuck marker's motion over that
  /// deviation is chi-distributed with 3 degrees of freedom, so the probability that noise
  /// alone marks it as slipping is P(chi^2_3 > k^2): 2.9e-2 for k = 3, 1.1e-3 for k = 4,
  /// 1.5e-5 for k = 5.
  double slip_sigmas = 4.0;
  /// Measure a marker's motion in the surface's tangent plane only (the component along its
  /// world normal removed) instead of the whole 3D motion (the paper's). Pressing and
  /// lifting move contact markers along the normal without sliding on the object; counted,
  /// they make slip points whose force ratio is not mu (rising during a lift, where F_n
  /// drops under a held tangential load). The threshold stays k sqrt(2 (...)) (conservative
  /// for two components).
  bool tangential_motion = false;

  /// mu_i = the tangential force's component against the marker's slip, max(0, -F_t . s) /
  /// F_n with s the unit direction of its motion on the object, instead of |F_t| / F_n (the
  /// paper's). Coulomb friction on a slipping point is antiparallel to its slip, so the
  /// component across the slip is measurement error; |F_t| adds that error in quadrature and
  /// is biased up where F_t is small (low mu), the projection is not. The motion's direction
  /// is known to about the position noise over the motion (0.003 / 0.08 mm = 0.04 rad on the
  /// twin scenes: cos 0.04 = 0.999).
  bool friction_along_slip = false;

  // ---- Gross slip ----
  /// Only slip points of frames in steady gross slip vote for mu (equations 5 and 6). A frame
  /// is in steady gross slip when every marker pressed over contact_threshold_n in it and in
  /// the previous frame (a) moved on the object by more than SlipThresholdMm() and (b) kept
  /// its position in the sensor frame, tangentially, within slip_sigmas sqrt(2)
  /// marker_noise_mm: the whole contact slides and its deformation no longer changes, so
  /// every contact point is on its friction cone and |F_t| / F_n is mu. While a stroke starts
  /// (the cover's shear still builds up, part of the contact sticks: partial slip), when it
  /// stops and during a lift, (b) fails: the markers move in the sensor frame by 0.02-0.15 mm
  /// a frame on the twin scenes against 0.002-0.005 mm in steady sliding (docs/friction.md).
  /// false (the paper): every slip point votes.
  bool gross_slip_only = false;
  /// With gross_slip_only, the frames before and after a slip point's frame, in its stroke,
  /// that must be in steady gross slip too (>= 0). 0: the frame alone (criterion (b) already
  /// sees the onset and the stop); more trims the steady runs' ends.
  int gross_slip_margin = 0;

  // ---- Resampling and reconstruction ----
  /// Edge of the voxels the cloud is averaged in (mm, > 0): resampling makes it uniform and
  /// smooths the markers' noise.
  double voxel_size_mm = 0.25;
  /// Octree depth of the Poisson reconstruction (in [4, 12]): the finest cell is the cloud's
  /// bounding box times poisson_scale over 2^depth.
  int poisson_depth = 8;
  /// Ratio of the reconstruction's cube to the cloud's bounding box (in [1, 2]).
  double poisson_scale = 1.1;
  /// Threads for the reconstruction (in [0, kMaxThreads]; 0: one a core). More than the
  /// machine's cores are run as one a core (Open3D's Poisson crashed with more). The cores are
  /// shared, so 1 by default; set OMP_WAIT_POLICY=PASSIVE in the environment.
  int num_threads = 1;
  static constexpr int kMaxThreads = 1024;
  /// Mesh vertices farther than this from every resampled point are dropped (mm, > 0): the
  /// Poisson surface closes the open patch, and only where there were points is it measured.
  /// 1 mm is a little over half the diagonal of the marker grid's cell (1.27 mm pitch: 0.9
  /// mm), so the patch of a single press, sampled only at the markers, stays whole.
  double trim_distance_mm = 1.0;

  // ---- Equations 5 and 6 ----
  /// r: slip points within this distance of a vertex vote for its mu (mm, > 0).
  double radius_mm = 1.5;
  /// alpha (>= 0, finite): w_i = (r - r_i)^alpha mu_i^beta. Large alpha favours the slip
  /// points nearest the vertex; 0 weighs all points in r alike.
  double alpha = 1.0;
  /// beta (>= 0, finite): large beta lowers the weight of small mu_i, which come from stuck
  /// markers misjudged as slipping (the paper selects a large beta).
  double beta = 2.0;
  /// gamma (>= 0, finite): the weights also take F_n^gamma, w_i = (r - r_i)^alpha mu_i^beta
  /// F_n,i^gamma. Not in the paper (0 leaves its equation 6 as it is). With beta = 0 and
  /// gamma = 1, equation 5 becomes sum w |F_t,i| / sum w F_n,i, the ratio of the forces summed
  /// near the vertex: per-marker forces from the force inverse are smoothed over neighbouring
  /// markers, so the ratio of one marker's components is noisy (worst at the contact's edge,
  /// where F_n is small) while sums over a neighbourhood are not (docs/friction.md, twin
  /// evaluation).
  double normal_force_exponent = 0.0;
  /// A vertex with fewer slip points than this within r keeps mu unknown (NaN) (>= 1): at the
  /// rim of the scanned patch a vertex sees only a few markers at the contact's edge, where
  /// F_n is small and the force ratio least reliable. 1 (the paper): any slip point will do.
  int min_slip_points = 1;
  /// A vertex keeps mu unknown (NaN) when the centre of its slip points, weighted by
  /// SupportWeight (equation 6 without mu_i^beta: where the data lie, not what they say),
  /// lies farther than this fraction of r from it (in (0, 1]): its mu would be extrapolated
  /// from one side. At the rim of the scanned patch every slip point near a vertex
  /// lies inward of it (on a straight rim of uniform slip points the centre is 4r / (3 pi) =
  /// 0.42 r inward), and they are the markers at one edge of the contact, whose force ratio
  /// the force inverse biases one way. 1 (the paper): no such test.
  double max_support_offset = 1.0;

  /// These options with cover_thickness_mm = sensor.markers.depth_mm.
  FrictionMapOptions WithSensor(const SensorConfig& sensor) const;

  /// slip_contact_threshold_n, or contact_threshold_n where that is < 0 (N).
  double SlipContactThresholdN() const {
    return slip_contact_threshold_n < 0 ? contact_threshold_n : slip_contact_threshold_n;
  }

  /// k sqrt(2 (marker_noise^2 + pose_noise^2)) in mm.
  double SlipThresholdMm() const;

  /// @throws tac3d::Error naming the field and its bound.
  void Validate() const;
};

/// A contact marker that moved relative to the object between two adjacent frames, with its
/// preliminary friction estimate.
struct SlipPoint {
  Eigen::Vector3d p_in_world_mm = Eigen::Vector3d::Zero();  ///< on the object's surface
  double mu = 0.0;                                          ///< mu_i = |F_t| / F_n (>= 0)
  double normal_force_n = 0.0;   ///< F_n = -(f . n) (> contact threshold)
  double motion_mm = 0.0;        ///< world motion of the marker since the previous frame
  std::int64_t frame_index = 0;  ///< TactileFrame::index of the later frame
  int marker = 0;                ///< marker index (row * cols + col)
  /// Set by Build: the frame and gross_slip_margin frames on either side, in its stroke, were
  /// in steady gross slip (FrictionMapOptions::gross_slip_only).
  bool gross_slip = false;
};

enum class FrictionMapStatus {
  kNotRun,
  kOk,
  /// No marker was ever in contact: no cloud, no mesh.
  kNoContact,
  /// Fewer resampled points than a reconstruction needs (kMinReconstructionPoints).
  kTooFewPoints,
  /// Poisson returned no surface near the points (every vertex trimmed).
  kReconstructionFailed,
  /// A mesh, but no slip point: every vertex's mu is unknown.
  kNoSlip,
};
std::string ToString(FrictionMapStatus status);

/// What the build saw and did. Fields start at "not run" values.
struct FrictionMapSummary {
  FrictionMapStatus status = FrictionMapStatus::kNotRun;
  std::string message;
  int frames = 0;           ///< frames added and used
  int frames_skipped = 0;   ///< frames with initialize_progress < 100
  long contact_points = 0;  ///< surface points collected (contact markers over all frames)
  long marker_pairs = 0;    ///< markers valid and in contact in two adjacent frames
  long slip_points = 0;
  /// Frames in steady gross slip (FrictionMapOptions::gross_slip_only), and the slip points
  /// that voted for mu (over contact_threshold_n; with gross_slip_only, in steady gross slip
  /// with its margin).
  int gross_slip_frames = 0;
  long voting_slip_points = 0;
  double slip_threshold_mm = 0.0;
  /// Per-axis noise of one position estimated from the pairs judged stuck:
  /// sqrt(sum |d|^2 / (6 n)). Compare with marker_noise_mm (NaN: no stuck pair).
  double estimated_noise_mm = std::numeric_limits<double>::quiet_NaN();
  long resampled_points = 0;
  long poisson_vertices = 0;  ///< before trimming
  long vertices = 0;
  long triangles = 0;
  long unknown_vertices = 0;  ///< no slip point within r: mu is NaN
  double unknown_fraction = std::numeric_limits<double>::quiet_NaN();
  double mu_min = std::numeric_limits<double>::quiet_NaN();  ///< over known vertices
  double mu_median = std::numeric_limits<double>::quiet_NaN();
  double mu_max = std::numeric_limits<double>::quiet_NaN();
  double resample_time_s = 0.0;
  double poisson_time_s = 0.0;
  double trim_time_s = 0.0;
  double mu_time_s = 0.0;
  double total_time_s = 0.0;

  /// One line: status, frames, points, slip points, vertices, unknown fraction, times.
  std::string BriefReport() const;
};
nlohmann::json ToJson(const FrictionMapSummary& summary);
/// The options a map was built with, as used (the slip thresholds derived), for its summary.
nlohmann::json ToJson(const FrictionMapOptions& options);

/// The friction map: a triangle mesh of the object's surface in the world frame with mu per
/// vertex (equations 5 and 6), and the slip points it came from.
struct FrictionMapResult {
  std::vector<Eigen::Vector3d> vertices_mm;     ///< world frame
  std::vector<Eigen::Vector3i> triangles;       ///< vertex indices
  std::vector<Eigen::Vector3d> vertex_normals;  ///< unit, outward of the object
  std::vector<double> mu;                       ///< per vertex; NaN: unknown
  std::vector<double> confidence;               ///< per vertex: sum of w_i (0 where unknown)
  std::vector<int> slip_count;                  ///< per vertex: slip points within r
  std::vector<SlipPoint> slip_points;
  FrictionMapSummary summary;
};

/// Progress of a long computation: (steps done, total steps).
using ProgressCallback = std::function<void(int done, int total)>;

/// Accumulates a stream of tactile frames with the sensor's pose and builds the friction
/// map of the fixed object the sensor slid over (paper section IV.B).
///
/// Per frame (AddFrame): each valid marker's force splits along its outward normal n into
/// F_n = -(f . n) and F_t = f + F_n n; markers with F_n > contact_threshold_n are in contact;
/// their positions moved cover_thickness_mm along n and mapped to the world are the object's
/// surface points (normal -n: outward of the object). A marker valid and in contact in this
/// frame and the previous one whose world position moved more than SlipThresholdMm() is a
/// slip point with mu_i = |F_t| / F_n (this frame's forces).
///
/// Build: voxel resampling, Poisson reconstruction (Open3D), trimming to the points, and mu
/// at every vertex by equations 5 and 6 over the slip points within r (Open3D's kd-tree).
/// Open3D 0.16 from Debian (`libopen3d-dev`) rather than PCL: it brought 30 new packages on
/// this machine against PCL's ~480 (`libpcl-dev`), and its Poisson is about twice as fast
/// (DESIGN.md). The marker's own contact flags (TactileFrame::contact) are not used: the
/// contact region is this module's threshold on the normal force, as in the paper.
class FrictionMapBuilder {
 public:
  /// @throws Error from options.Validate().
  explicit FrictionMapBuilder(const FrictionMapOptions& options);

  /// Adds the next frame. Frames with initialize_progress < 100 are skipped (and break the
  /// adjacency for slip detection).
  /// @param world_from_sensor the sensor's pose at frame.timestamp_s.
  /// @throws Error from frame.Validate(), or naming the frame if the pose is not rigid.
  void AddFrame(const TactileFrame& frame, const Rigid3& world_from_sensor);

  /// AddFrame, then BreakStroke if no valid marker of the frame presses over
  /// contact_threshold_n (the sensor was lifted): how the frames of a recording are added,
  /// by `tac3d friction-map --recording` and Python's tac3d.friction_map alike.
  void AddFrameOfStrokes(const TactileFrame& frame, const Rigid3& world_from_sensor);

  /// Forgets the previous frame, so the next one starts a new stroke (no slip points
  /// between strokes, e.g. after the sensor was lifted and moved).
  void BreakStroke();

  /// Builds the mesh and the friction map from everything added so far. Problems with the
  /// data (no contact, too few points, no slip) are reported in summary.status, not thrown.
  ///
  /// Time: a 3000-frame session (six 40 mm strokes at 0.08 mm a frame, ~96k contact points)
  /// is added and built in about 1.8 s on one core, Poisson (depth 8, 0.25 mm voxels) 1.0 s of
  /// it (bench/friction_benchmark.cc, docs/friction.md).
  /// @param progress called after each of the four stages (resample, reconstruct, trim, mu).
  FrictionMapResult Build(const ProgressCallback& progress = {}) const;

  const FrictionMapOptions& options() const { return options_; }
  /// Surface points collected so far (world, on the object's surface) and their normals.
  const std::vector<Eigen::Vector3d>& surface_points() const { return surface_points_; }
  const std::vector<Eigen::Vector3d>& surface_normals() const { return surface_normals_; }
  const std::vector<SlipPoint>& slip_points() const { return slip_points_; }

  /// Fewest resampled points Build reconstructs from.
  static constexpr long kMinReconstructionPoints = 20;

 private:
  /// Sets each slip point's gross_slip from the frames' motion; counts the gross-slip frames.
  void MarkGrossSlip(std::vector<SlipPoint>& slips, int* gross_frames) const;

  FrictionMapOptions options_;
  std::vector<Eigen::Vector3d> surface_points_;
  std::vector<Eigen::Vector3d> surface_normals_;
  std::vector<SlipPoint> slip_points_;
  // The previous frame's markers in the world, and whether each was valid and in contact.
  std::vector<Eigen::Vector3d> previous_world_mm_;
  std::vector<Eigen::Vector3d> previous_sensor_mm_;  // the previous frame's positions_mm
  std::vector<bool> previous_contact_;
  std::vector<Eigen::Vector3d> current_world_mm_;
  std::vector<bool> current_contact_;
  // Per frame added with a previous one: its index, stroke and whether it was in steady gross
  // slip.
  struct FrameMotion {
    std::int64_t index = 0;
    int stroke = 0;
    bool gross_slip = false;
  };
  std::vector<FrameMotion> frame_motion_;
  int stroke_ = 0;
  int frames_ = 0;
  int frames_skipped_ = 0;
  long marker_pairs_ = 0;
  double stuck_sum_squared_mm2_ = 0.0;
  long stuck_pairs_ = 0;
};

/// mu at a point from the slip points within r (equations 5 and 6):
/// mu = sum w_i mu_i / sum w_i, w_i = (r - r_i)^alpha mu_i^beta. When every weight is zero
/// (all mu_i = 0 with beta > 0, or all r_i = r with alpha > 0), the plain mean of the mu_i,
/// the weights' limit as they become equal. NaN without slip points.
/// @param mu_i, distance_mm the slip points' estimates and distances (r_i <= r).
/// @param weight_sum set to sum w_i.
/// @param normal_force_n the slip points' F_n for the F_n^gamma factor (empty: gamma ignored).
/// The part of a slip point's weight in equation 5 that does not depend on its mu_i:
/// (r - r_i)^alpha F_n,i^gamma (the F_n factor with normal_force_n >= 0 only; < 0: none).
/// w_i = SupportWeight mu_i^beta.
double SupportWeight(double distance_mm, double normal_force_n, const FrictionMapOptions& options);

double WeightedFriction(const std::vector<double>& mu_i,
                        const std::vector<double>& distance_mm,
                        const FrictionMapOptions& options,
                        double* weight_sum,
                        const std::vector<double>& normal_force_n = {});

}  // namespace tac3d::friction
