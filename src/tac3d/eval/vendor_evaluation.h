#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tac3d/fem/compliance.h"
#include "tac3d/force/force_gains.h"
#include "tac3d/force/force_reconstructor.h"
#include "tac3d/force/regularization.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/util/eval_check.h"
#include "tac3d/vendor_formats/vendor_gel.h"
#include "tac3d/vendor_formats/vendor_recording.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

namespace tac3d {

/// The force part of `tac3d eval vendor`: tac3d's inverse on the recording's displacements
/// against the recording's resultant.
struct VendorForceOptions {
  /// The gel's assumptions (thickness, marker depth, footprint, mesh).
  VendorGelOptions gel = {};
  /// Frames whose recorded resultant |3D_ResultantForce| exceeds this (N) are compared.
  double min_resultant_n = 1.0;
  /// The inverse checked: `tac3d run`'s for the sensor (DefaultPipelineOptions), with the
  /// weight w ((mm/N)^2) and the contact-support re-solve given here, as `tac3d run --weight
  /// --support-resolve` takes them; unset: the sensor's defaults.
  std::optional<double> weight{};
  std::optional<bool> support_resolve{};
  /// Morozov's tau of the figure given for reference: F = K D at the discrepancy principle's
  /// weight for the datasheet's position noise (SelectRegularizationWeight, kDiscrepancy) on
  /// the compared frames.
  double discrepancy_factor = 1.0;
  /// Where compliance models are cached (fem::LoadOrBuildComplianceModel); empty: built, not
  /// cached.
  std::string cache_dir = {};
  bool show_progress = false;

  /// @throws Error naming the field: min_resultant_n >= 0, discrepancy_factor >= 1, the gel's.
  void Validate() const;
};

struct VendorEvaluationOptions {
  /// The recording's frame whose reference positions (3D_Positions - 3D_Displacements) are
  /// compared; the vendor's zero-point correction moves them between frames.
  std::int64_t reference_frame = 0;
  VendorStereoOptions stereo = {};
  /// The force part; nullopt: the reference positions only (no FEM model is built).
  std::optional<VendorForceOptions> forces = std::nullopt;
};

/// Median, 95th percentile (linear interpolation, as NumPy's) and maximum of a set of errors.
struct ErrorSummary {
  double median = std::numeric_limits<double>::quiet_NaN();
  double p95 = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
  int count = 0;

  /// @pre values is not empty.
  static ErrorSummary Of(std::vector<double> values);
};

/// One resultant estimate against the recording's 3D_ResultantForce R, frame by frame, in % of
/// that frame's |R|: per axis |F_a - R_a| / |R|, of the magnitude ||F| - |R|| / |R|, and of
/// the vector |F - R| / |R|.
struct ResultantErrors {
  std::array<ErrorSummary, 3> axis_pct;
  ErrorSummary magnitude_pct;
  ErrorSummary vector_pct;
  /// The median over frames of |F| / |R| (a scale error shows here with its sign).
  double median_magnitude_ratio = std::numeric_limits<double>::quiet_NaN();
  /// The median over frames of F (N), per axis.
  Eigen::Vector3d median_resultant_n = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

/// What the force part measured, and with which gel model.
struct VendorForceEvaluation {
  VendorForceOptions options;
  /// The FEM body the compliance was built on (VendorBodyModelOptions), and it in words.
  fem::BodyModelOptions body;
  std::string gel_description;
  fem::ComplianceProvenance compliance;
  /// The inverse checked (`tac3d run`'s: its weight and re-solve; no gains).
  ForceReconstructorOptions inverse;
  /// The datasheet's position noise (1 sigma per axis, mm) and the weight the discrepancy
  /// principle picks for it on the compared frames.
  Eigen::Vector3d position_noise_mm = Eigen::Vector3d::Zero();
  WeightSelection discrepancy_weight;
  /// Frames compared (recorded |R| over min_resultant_n), and of them the ones the
  /// contact-support re-solve ran on (the others keep F = K D: no support, or one over
  /// ForceReconstructorOptions::max_support_markers).
  int frames_compared = 0;
  int frames_support_refined = 0;
  /// Frames over min_resultant_n left out: a marker's or the resultant's value not finite.
  int frames_not_finite = 0;
  /// The median over compared frames of the recorded R (N).
  Eigen::Vector3d median_recorded_resultant_n = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// tac3d's forces as `tac3d run --recompute-forces` computes them (Pipeline::RecomputeForces
  /// with `inverse`: what the check judges); beside it, for reference, the same weight with the
  /// contact-support re-solve on, F = K D at the discrepancy principle's weight, and the sum of
  /// the vendor's per-marker 3D_Forces.
  ResultantErrors tac3d;
  ResultantErrors tac3d_support_resolve;
  ResultantErrors tac3d_discrepancy_weight;
  ResultantErrors vendor_marker_sum;
};

/// What EvaluateVendorRecording measured.
struct VendorEvaluation {
  /// In this order: reference_position_error_median_mm <= 0.06 mm,
  /// reference_position_error_max_mm <= 0.15 mm, untriangulated_markers <= 0; with the force
  /// part, resultant_magnitude_error_median_pct <= 10 % (n/a without a frame over the limit).
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  std::string serial_number;
  std::int64_t frames = 0;
  std::int64_t markers = 0;
  VendorEvaluationOptions options;
  /// |triangulated reference pixels - the recording's reference positions|, marker by marker.
  ErrorSummary reference_position_error_mm;
  /// Per axis: median of |error| in x, y, z.
  Eigen::Vector3d reference_position_median_abs_error_mm = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The gap between each marker's two rays (the model's self-consistency).
  ErrorSummary ray_gap_mm;
  int untriangulated_markers = 0;
  /// The force part, when asked for.
  std::optional<VendorForceEvaluation> forces;

  /// The checks, the figures and the verdict, as the CLI prints them.
  std::string Report() const;
};

/// {"checks", "all_pass", "pass", "serial_number", "frames", "markers", "reference_frame",
///  "undistort", "refract", "reference_position_error_mm" {"median", "p95", "max"},
///  "reference_position_median_abs_error_mm" {"x", "y", "z"}, "ray_gap_mm" {...},
///  "untriangulated_markers", "acceptance" ({check name: tolerance}), and with the force part
///  "resultant_error_pct" {"x", "y", "z", "magnitude", "vector": {"median", "p95", "max",
///  "count"}, "median_magnitude_ratio", "median_resultant_n"}, "inverse" {"weight",
///  "support_resolve", "sensor_defaults"}, "vendor_marker_sum_error_pct", "support_resolve_error_pct"
///  and "discrepancy_weight_error_pct" (each as "resultant_error_pct"), "frames_compared",
///  "frames_support_refined", "min_resultant_n", "median_recorded_resultant_n",
///  "position_noise_mm", "discrepancy_weight" (WeightSelection), "gel" {"assumptions",
///  "description", "body", "compliance"}}.
nlohmann::json ToJson(const VendorEvaluation& evaluation);

/// `tac3d eval vendor`: the imported calibration's reference pixels triangulated (VendorStereo)
/// against the reference positions the vendor's software recorded, index for index; with
/// options.forces, EvaluateVendorForces too.
/// @throws Error if the config has no vendor camera model, the recording is of another sensor
///   (serial number) or marker count, or the reference frame is not in the recording.
VendorEvaluation EvaluateVendorRecording(const SensorConfig& config, const VendorRecording& recording,
                                         const VendorEvaluationOptions& options = {});

/// The force part: the gel's compliance H (VendorBodyModelOptions, loaded or built and cached)
/// and `tac3d run --recompute-forces`'s forces (Pipeline::RecomputeForces: the sensor's default
/// inverse unless options.weight or support_resolve say otherwise; no gains, nothing fitted to
/// the recorded forces) on each compared frame's recorded markers, against its
/// 3D_ResultantForce; beside them the same weight with the re-solve on, F = K D at the
/// discrepancy principle's weight, and the sum of the vendor's 3D_Forces.
/// @throws Error if the options or the gel are invalid, or the recording is of another marker
///   count than the config.
VendorForceEvaluation EvaluateVendorForces(const SensorConfig& config, const VendorRecording& recording,
                                           const VendorForceOptions& options);

/// What CalibrateGainsOnVendorRecording fitted.
struct VendorGainCalibration {
  /// The gains (PoorGainFit::kLeaveAtOne: an axis the recording does not determine is left at
  /// 1, ForceGainFit::left_at_one says why), over the compared frames' (tac3d's resultant with
  /// unit gains, the recorded resultant) pairs.
  ForceGainFit fit;
  /// The inverse the resultants came from (`tac3d run`'s for the sensor, as the options say).
  ForceReconstructorOptions inverse;
  int frames_compared = 0;
  int frames_not_finite = 0;
};

/// `tac3d calibrate-force --vendor-recording`: adopts the vendor's factory calibration of the
/// resultant. Each compared frame's forces are recomputed from its recorded displacements as
/// `tac3d run --recompute-forces` does (EvaluateVendorForces' frames, unit gains), and per-axis
/// gains are fitted to the recorded 3D_ResultantForce (FitForceGains), only on the axes the
/// recording determines (R^2 >= fit_options.min_r_squared, a positive gain): the others are
/// left at 1.
/// @throws Error if the options are invalid, the recording is of another marker count, or
///   fewer than kMinForcePairs frames are over options.min_resultant_n.
VendorGainCalibration CalibrateGainsOnVendorRecording(const SensorConfig& config, const VendorRecording& recording,
                                                      const VendorForceOptions& options,
                                                      ForceGainFitOptions fit_options = {});

}  // namespace tac3d
