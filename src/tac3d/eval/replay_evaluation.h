#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/force/force_gains.h"
#include "tac3d/frame/tactile_frame.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// How a twin dataset is replayed through the Pipeline and judged against its truth.
struct ReplayOptions {
  /// The pipeline as it runs on the sensor (reference_frames, w, gains, contact, ...).
  PipelineOptions pipeline;
  /// Full scales the force errors are expressed in (N): the normal axis z and the tangential
  /// axes x, y (the prototype's rated range, docs/force.md).
  double full_scale_normal_n = 10.0;
  double full_scale_tangential_n = 5.0;
  /// A frame is "loaded" when the true total force exceeds this (N); the force errors and
  /// the force pairs are taken over loaded frames.
  double loaded_force_n = 0.1;
  /// The first reference_frames steps must carry at most this true force (N): the pipeline
  /// takes them as the undeformed reference.
  double reference_force_tolerance_n = 1e-6;
  /// Replay only the first N steps (0: all).
  int max_steps = 0;
  /// The acceptance bound on the per-frame resultant error (% of full scale, each axis).
  double max_force_error_pct_fs = 2.0;
  /// CalibrateGainsByReplay's fit: its R^2 floor, and whether a fit under it is refused or
  /// returned flagged (ForceGainFit::usable).
  ForceGainFitOptions gain_fit;

  /// @throws Error naming the field and its bound.
  void Validate() const;
};

/// One replayed frame: the pipeline's output against the dataset's truth.
struct ReplayFrame {
  int step = 0;
  bool loaded = false;
  std::uint32_t flags = 0;  ///< the TactileFrame's FrameFlag bits
  Eigen::Vector3d true_force_n = Eigen::Vector3d::Zero();
  Eigen::Vector3d measured_force_n = Eigen::Vector3d::Zero();
  Eigen::Vector3d true_moment_nmm = Eigen::Vector3d::Zero();
  Eigen::Vector3d measured_moment_nmm = Eigen::Vector3d::Zero();
  int valid_markers = 0;
  int true_contact_markers = 0;
  int measured_contact_markers = 0;
  int contact_agreeing_markers = 0;  ///< markers whose contact state matches the truth
  int contact_both_markers = 0;      ///< markers in contact in both
  double position_rmse_mm = 0.0;      ///< over the valid markers
  double displacement_rmse_mm = 0.0;  ///< against (true position - true rest position)
};

/// Figures over the frames after the reference (RMS and max per axis x, y, z).
struct ReplaySummary {
  int steps = 0;            ///< dataset steps replayed (reference included)
  int frames = 0;           ///< frames after the reference
  int loaded_frames = 0;
  int flagged_frames = 0;   ///< frames with any flag
  std::vector<std::pair<std::string, int>> flag_counts;  ///< frames per flag, bit order
  long lost_marker_frames = 0;  ///< sum over frames of the invalid markers
  Eigen::Vector3d force_error_max_pct_fs = Eigen::Vector3d::Zero();
  Eigen::Vector3d force_error_rms_pct_fs = Eigen::Vector3d::Zero();
  int worst_force_step = -1;  ///< the step of the largest error in % FS over the axes
  Eigen::Vector3d moment_error_max_nmm = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment_error_rms_nmm = Eigen::Vector3d::Zero();
  double position_rmse_mm = 0.0;
  double displacement_rmse_mm = 0.0;
  /// Fraction of marker-frames whose contact state matches the truth, and the intersection
  /// over union of the two contact sets, over loaded frames.
  double contact_agreement = 0.0;
  double contact_iou = 0.0;
  double seconds = 0.0;
};

struct ReplayResult {
  std::vector<ReplayFrame> frames;  ///< frames after the reference, in step order
  ReplaySummary summary;
};

/// What a replay changes in what the sensor sees (`tac3d eval conditions`): each step may be
/// altered before the pipeline sees it (its image re-rendered, its time moved), and frames may
/// be fed to the pipeline between the reference and the first step after it.
struct ReplayAlterations {
  /// Called with each step as read, and whether it is one of the reference steps.
  std::function<void(TwinStep&, bool reference)> step;
  /// Called once the reference steps are processed, with the pipeline and the last of them.
  std::function<void(Pipeline&, const TwinStep&)> after_reference;
};

/// The sensor a dataset was simulated with: the scene its header names (a built-in name, or
/// a scene file that still exists) gives it.
/// @throws Error if the header names no scene that can be loaded (pass the sensor instead).
SensorConfig DatasetSensor(const TwinDatasetReader& dataset);

/// Replays a twin dataset's images through a Pipeline built on `config` and the nominal
/// compliance (h, fem_markers_mm), and compares every frame after the reference with the
/// truth (paper section V).
/// @param progress called after each step with (steps done, steps in all), may be empty.
/// @param on_frame called with each frame after the reference and its truth, may be empty.
/// @param alter changes to what the sensor sees (ReplayAlterations), may be empty.
/// @throws Error if the options are invalid, a step lacks its image, the markers disagree
///   with the sensor, or a step among the first reference_frames carries force (the pipeline
///   would take a loaded state as its reference).
ReplayResult ReplayTwinDataset(const TwinDatasetReader& dataset, const SensorConfig& config,
                               const Eigen::MatrixXd& h,
                               const std::vector<Eigen::Vector3d>& fem_markers_mm,
                               const ReplayOptions& options,
                               const std::function<void(int, int)>& progress = {},
                               const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame = {},
                               const ReplayAlterations& alter = {});

/// The force-calibration pairs of a replay: per loaded frame, the pipeline's resultant with
/// unit gains (the measured resultant divided by the gains the replay ran with: the gains
/// scale the forces last, ForceReconstructor) and the true total force.
std::vector<ForcePair> ReplayForcePairs(const ReplayResult& replay, const Eigen::Vector3d& gains);

/// A force calibration by replay (paper section V.A with the twin as the reference sensor):
/// the calibration dataset replayed with unit gains, its pairs and the gains fitted to them.
struct ReplayGainCalibration {
  ReplayResult replay;
  std::vector<ForcePair> pairs;
  ForceGainFit fit;
};

/// Replays `calibration` with options.pipeline's gains set to one and fits the gains
/// (FitForceGains, with options.gain_fit) to its force pairs.
/// @throws Error as ReplayTwinDataset and FitForceGains do.
ReplayGainCalibration CalibrateGainsByReplay(const TwinDatasetReader& calibration,
                                             const SensorConfig& config, const Eigen::MatrixXd& h,
                                             const std::vector<Eigen::Vector3d>& fem_markers_mm,
                                             ReplayOptions options,
                                             const std::function<void(int, int)>& progress = {});

/// The summary as JSON, with the acceptance checks (`checks`: the per-axis max resultant
/// error <= max_force_error_pct_fs) and `all_pass`.
nlohmann::json ToJson(const ReplaySummary& summary, const ReplayOptions& options);

/// One line a frame: step, loaded, flags, true and measured force and moment, markers.
std::string ReplayFramesToCsv(const std::vector<ReplayFrame>& frames);

}  // namespace tac3d
