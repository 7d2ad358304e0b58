#include "tac3d/vendor/vendor_evaluation.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/json_number.h"

namespace tac3d {
namespace {

// The q-quantile of sorted values, interpolated linearly between neighbours (NumPy's default).
double SortedQuantile(const std::vector<double>& sorted, double q) {
  const double position = q * static_cast<double>(sorted.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (position - static_cast<double>(below)) * (sorted[above] - sorted[below]);
}

nlohmann::json Json(const ErrorSummary& s) {
  return {{"median", FiniteOrNull(s.median)}, {"p95", FiniteOrNull(s.p95)}, {"max", FiniteOrNull(s.max)}, {"count", s.count}};
}

}  // namespace

ErrorSummary ErrorSummary::Of(std::vector<double> values) {
  TAC3D_DEMAND(!values.empty());
  std::sort(values.begin(), values.end());
  ErrorSummary s;
  s.median = SortedQuantile(values, 0.5);
  s.p95 = SortedQuantile(values, 0.95);
  s.max = values.back();
  s.count = static_cast<int>(values.size());
  return s;
}

std::string VendorEvaluation::Report() const {
  std::string text = FormatChecks(checks);
  text += fmt::format("sensor {}: {} markers, {} frames; reference positions of frame {}{}{}\n", serial_number, markers,
                      frames, options.reference_frame, options.stereo.undistort ? "" : ", without distortion",
                      options.stereo.refract ? "" : ", without refraction");
  const ErrorSummary& e = reference_position_error_mm;
  text += fmt::format("reference position error: median {:.4f} mm, p95 {:.4f} mm, max {:.4f} mm ({} markers)\n",
                      e.median, e.p95, e.max, e.count);
  const Eigen::Vector3d& axis = reference_position_median_abs_error_mm;
  text += fmt::format("median |error| x / y / z: {:.4f} / {:.4f} / {:.4f} mm\n", axis.x(), axis.y(), axis.z());
  text += fmt::format("gap between each marker's two rays: median {:.4f} mm, max {:.4f} mm\n", ray_gap_mm.median,
                      ray_gap_mm.max);
  return text + fmt::format("all pass: {}\n", all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const VendorEvaluation& e) {
  nlohmann::json acceptance = nlohmann::json::object();
  for (const EvalCheck& check : e.checks) acceptance[check.name] = check.tolerance;
  const Eigen::Vector3d& axis = e.reference_position_median_abs_error_mm;
  return {{"checks", ToJson(e.checks)},
          {"all_pass", e.all_pass},
          {"pass", e.all_pass},
          {"serial_number", e.serial_number},
          {"frames", e.frames},
          {"markers", e.markers},
          {"reference_frame", e.options.reference_frame},
          {"undistort", e.options.stereo.undistort},
          {"refract", e.options.stereo.refract},
          {"reference_position_error_mm", Json(e.reference_position_error_mm)},
          {"reference_position_median_abs_error_mm",
           {{"x", FiniteOrNull(axis.x())}, {"y", FiniteOrNull(axis.y())}, {"z", FiniteOrNull(axis.z())}}},
          {"ray_gap_mm", Json(e.ray_gap_mm)},
          {"untriangulated_markers", e.untriangulated_markers},
          {"acceptance", acceptance}};
}

VendorEvaluation EvaluateVendorRecording(const SensorConfig& config, const VendorRecording& recording,
                                         const VendorEvaluationOptions& options) {
  const VendorStereo stereo(config, options.stereo);
  const VendorCameraModelConfig& model = *config.vendor_camera;
  if (recording.serial_number != model.serial_number) {
    throw Error(fmt::format("the recording is of sensor '{}', the config of sensor '{}'", recording.serial_number,
                            model.serial_number));
  }
  const std::int64_t markers = config.markers.rows * config.markers.cols;
  if (recording.markers() != markers) {
    throw Error(fmt::format("the recording has {} markers, the config {}", recording.markers(), markers));
  }
  if (options.reference_frame < 0 || options.reference_frame >= recording.frames()) {
    throw Error(fmt::format("reference frame {} is not in the recording's {} frames", options.reference_frame,
                            recording.frames()));
  }
  VendorEvaluation e;
  e.serial_number = recording.serial_number;
  e.frames = recording.frames();
  e.markers = markers;
  e.options = options;
  const Eigen::MatrixX3d reference = recording.ReferencePositions(options.reference_frame);
  const std::vector<Triangulation> triangulated = stereo.TriangulateReference();
  std::vector<double> errors, gaps;
  std::array<std::vector<double>, 3> axis_errors;
  for (std::int64_t i = 0; i < markers; ++i) {
    const Triangulation& t = triangulated[i];
    if (!t.valid) {
      ++e.untriangulated_markers;
      continue;
    }
    const Eigen::Vector3d error = t.point - reference.row(i).transpose();
    errors.push_back(error.norm());
    gaps.push_back(t.residual);
    for (int k = 0; k < 3; ++k) axis_errors[k].push_back(std::abs(error(k)));
  }
  if (!errors.empty()) {
    e.reference_position_error_mm = ErrorSummary::Of(errors);
    e.ray_gap_mm = ErrorSummary::Of(gaps);
    for (int k = 0; k < 3; ++k) e.reference_position_median_abs_error_mm(k) = ErrorSummary::Of(axis_errors[k]).median;
  }
  e.checks = {EvalCheck::AtMost("reference_position_error_median_mm", e.reference_position_error_mm.median, 0.06, "mm"),
              EvalCheck::AtMost("reference_position_error_max_mm", e.reference_position_error_mm.max, 0.15, "mm"),
              EvalCheck::AtMost("untriangulated_markers", e.untriangulated_markers, 0)};
  e.all_pass = AllPass(e.checks);
  return e;
}

}  // namespace tac3d
