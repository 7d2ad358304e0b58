#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/util/eval_check.h"
#include "tac3d/vendor/vendor_recording.h"
#include "tac3d/vendor/vendor_stereo.h"

namespace tac3d {

struct VendorEvaluationOptions {
  /// The recording's frame whose reference positions (3D_Positions - 3D_Displacements) are
  /// compared; the vendor's zero-point correction moves them between frames.
  std::int64_t reference_frame = 0;
  VendorStereoOptions stereo = {};
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

/// What EvaluateVendorRecording measured.
struct VendorEvaluation {
  /// In this order (issue 23's acceptance): reference_position_error_median_mm <= 0.06 mm,
  /// reference_position_error_max_mm <= 0.15 mm, untriangulated_markers <= 0.
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

  /// The checks, the figures and the verdict, as the CLI prints them.
  std::string Report() const;
};

/// {"checks", "all_pass", "pass", "serial_number", "frames", "markers", "reference_frame",
///  "undistort", "refract", "reference_position_error_mm" {"median", "p95", "max"},
///  "reference_position_median_abs_error_mm" {"x", "y", "z"}, "ray_gap_mm" {...},
///  "untriangulated_markers", "acceptance" ({check name: tolerance})}.
nlohmann::json ToJson(const VendorEvaluation& evaluation);

/// `tac3d eval vendor`: the imported calibration's reference pixels triangulated (VendorStereo)
/// against the reference positions the vendor's software recorded, index for index.
/// @throws Error if the config has no vendor camera model, the recording is of another sensor
///   (serial number) or marker count, or the reference frame is not in the recording.
VendorEvaluation EvaluateVendorRecording(const SensorConfig& config, const VendorRecording& recording,
                                         const VendorEvaluationOptions& options = {});

}  // namespace tac3d
