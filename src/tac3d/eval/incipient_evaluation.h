#pragma once

#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/util/eval_check.h"

namespace tac3d {

struct TwinStep;

/// The twin's truth of one step for incipient slip: the resultant's normal and
/// tangential parts, their ratio to the friction cone and the stuck part of the contact.
struct IncipientTruth {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double t_s = 0.0;
  double normal_force_n = 0.0;      ///< P: the object's push into the fingertip (-F_z), N
  double tangential_force_n = 0.0;  ///< Q = |(F_x, F_y)|, N
  double mu = kNaN;                 ///< the surface's friction coefficient
  double load_ratio = kNaN;         ///< Q / (mu P); NaN without contact
  int contact_nodes = 0;            ///< surface nodes in contact (stick or slip)
  int stick_nodes = 0;
  double stick_area_mm2 = 0.0;      ///< stick nodes x the grid's cell area

  bool in_contact() const { return contact_nodes > 0; }
  /// Stick nodes / contact nodes; NaN without contact.
  double stick_fraction() const;
  /// In contact and no node sticks.
  bool gross_slip() const { return contact_nodes > 0 && stick_nodes == 0; }
};

/// The truth of a step read with its surface (TwinDatasetReader::Read(step, true), or a
/// TwinSimulation step with keep_surface).
/// @param mu the surface's friction coefficient (the scene's; the family's indenters have one).
/// @param cell_area_mm2 the twin's contact grid's cell (SurfaceGrid::cell_area_mm2).
/// @throws Error if the step has no surface tractions or mu, cell_area_mm2 are not > 0.
IncipientTruth IncipientTruthOf(const TwinStep& step, double mu, double cell_area_mm2);

/// One frame of a scene: the truth and the pipeline's live estimate (TactileFrame::slip).
struct IncipientFrame {
  IncipientTruth truth;
  FrameSlip estimate;
};

struct IncipientEvaluationOptions {
  /// The load-ratio window (Q / (mu P)) where mu and the margin are judged, before gross slip.
  double window_from = 0.5;
  double window_to = 0.9;
  /// "Within": |mu estimate - mu| <= this.
  double within_mu = 0.1;
  /// Pure stick: load ratio below this; a margin estimate under alarm_margin there is a false
  /// alarm.
  double stick_load_ratio = 0.3;
  double alarm_margin = 0.5;
  /// Coverage: |mu error| <= this many sigmas.
  double coverage_sigmas = 2.0;
  /// The acceptance targets.
  double target_mu_error_median = 0.05;
  double target_mu_error_p90 = 0.1;
  double target_lead_s = 0.3;  ///< on every slow ramp
  double target_false_alarm_rate = 0.01;
  /// The 2-sigma band covers the true mu in at least this fraction of the frames with an
  /// estimate.
  double target_coverage = 0.9;

  /// @throws Error naming the field: 0 <= window_from < window_to <= 1, target_coverage in
  /// (0, 1], the rest > 0.
  void Validate() const;
};

/// A scene's figures (or, from PoolIncipientEvaluations, all scenes'). Figures start at NaN
/// ("not measured": no frame to measure them on).
struct IncipientEvaluation {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::string scene;
  bool slow_ramp = false;
  double ramp_start_s = kNaN;
  int frames = 0;
  int contact_frames = 0;
  /// Frames in the window before gross slip, and of those the ones with a mu estimate.
  int window_frames = 0;
  int window_estimated_frames = 0;
  /// |mu estimate - mu| over the window's estimated frames; |margin estimate - (1 - load
  /// ratio)| over the window's frames with a margin.
  std::vector<double> mu_errors;
  std::vector<double> margin_errors;
  double mu_error_median = kNaN;
  double mu_error_p90 = kNaN;
  double margin_error_median = kNaN;
  double margin_error_p90 = kNaN;
  /// The first frame of the ramp whose contact slips as a whole (truth).
  double gross_slip_s = kNaN;
  /// From this time until gross slip every frame's mu estimate is within within_mu (NaN: the
  /// last frame before gross slip is not).
  double within_since_s = kNaN;
  /// gross_slip_s - within_since_s (0 if never within; NaN without gross slip), and that as a
  /// fraction of the ramp's time before gross slip. Pooled: the least over the slow ramps.
  double lead_s = kNaN;
  double lead_ramp_fraction = kNaN;
  int slow_ramps = 0;  ///< pooled: scenes with a slow ramp
  /// Frames in contact in pure stick, and those reporting a margin under alarm_margin.
  int stick_frames = 0;
  int false_alarms = 0;
  double false_alarm_rate = kNaN;
  /// Frames in contact with a mu estimate and a finite sigma, and those within
  /// coverage_sigmas of the truth.
  int sigma_frames = 0;
  int covered_frames = 0;
  double coverage = kNaN;
  /// The truth's range: the largest load ratio and the normal force at the ramp's start.
  double max_load_ratio = kNaN;
  double ramp_normal_force_n = kNaN;

  /// One line: the figures and counts.
  std::string BriefReport() const;
};

/// Judges one scene's frames (in time order).
/// @param ramp_start_s when the tangential ramp starts (gross slip before it, at touch-down, does
///   not count).
/// @throws Error if the options are invalid.
IncipientEvaluation EvaluateIncipient(const std::string& scene,
                                      const std::vector<IncipientFrame>& frames,
                                      double ramp_start_s,
                                      bool slow_ramp,
                                      const IncipientEvaluationOptions& options = {});

/// All scenes' figures together: errors and frame counts pooled, the lead the least over the
/// slow ramps (NaN when one has none).
IncipientEvaluation PoolIncipientEvaluations(const std::vector<IncipientEvaluation>& scenes);

/// The acceptance checks: mu_error_median, mu_error_p90, lead_ms_slow_ramps (least, >=),
/// false_alarm_rate, coverage (>=).
std::vector<EvalCheck> IncipientChecks(const IncipientEvaluation& e,
                                       const IncipientEvaluationOptions& options = {});

/// The figures (null where not measured) with "checks" and "all_pass" for the pooled one
/// (scene "overall").
nlohmann::json ToJson(const IncipientEvaluation& e, const IncipientEvaluationOptions& options = {});

}  // namespace tac3d
