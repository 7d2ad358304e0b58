#include "tac3d/eval/vendor_evaluation.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tac3d/force/force_reconstructor.h"
#include "tac3d/pipeline/pipeline.h"
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

nlohmann::json Json(const ResultantErrors& e) {
  const Eigen::Vector3d& f = e.median_resultant_n;
  return {{"x", Json(e.axis_pct[0])},
          {"y", Json(e.axis_pct[1])},
          {"z", Json(e.axis_pct[2])},
          {"magnitude", Json(e.magnitude_pct)},
          {"vector", Json(e.vector_pct)},
          {"median_magnitude_ratio", FiniteOrNull(e.median_magnitude_ratio)},
          {"median_resultant_n", {FiniteOrNull(f.x()), FiniteOrNull(f.y()), FiniteOrNull(f.z())}}};
}

nlohmann::json Json(const VendorForceEvaluation& f) {
  const Eigen::Vector3d& r = f.median_recorded_resultant_n;
  return {{"resultant_error_pct", Json(f.tac3d)},
          {"inverse", {{"weight", f.inverse.weight}, {"support_resolve", f.inverse.support_refinement},
                       {"sensor_defaults", !f.options.weight && !f.options.support_resolve}}},
          {"support_resolve_error_pct", Json(f.tac3d_support_resolve)},
          {"discrepancy_weight_error_pct", Json(f.tac3d_discrepancy_weight)},
          {"vendor_marker_sum_error_pct", Json(f.vendor_marker_sum)},
          {"frames_compared", f.frames_compared},
          {"frames_support_refined", f.frames_support_refined},
          {"frames_not_finite", f.frames_not_finite},
          {"min_resultant_n", f.options.min_resultant_n},
          {"median_recorded_resultant_n", {FiniteOrNull(r.x()), FiniteOrNull(r.y()), FiniteOrNull(r.z())}},
          {"position_noise_mm", {f.position_noise_mm.x(), f.position_noise_mm.y(), f.position_noise_mm.z()}},
          {"discrepancy_weight", ToJson(f.discrepancy_weight)},
          {"gel",
           {{"assumptions", ToJson(f.options.gel)},
            {"description", f.gel_description},
            {"body", fem::ToJson(f.body)},
            {"compliance", fem::ToJson(f.compliance)}}}};
}

// One line of the report: an estimate's errors in % of |R|.
std::string FormatResultantErrors(const std::string& name, const ResultantErrors& e) {
  const auto triple = [](const ErrorSummary& s) { return fmt::format("{:.2f} / {:.2f} / {:.2f}", s.median, s.p95, s.max); };
  return fmt::format("{}: median |F| / |R| {:.4f}; error in % of |R|, median / p95 / max: magnitude {}, x {}, y {}, "
                     "z {}, vector {}\n",
                     name, e.median_magnitude_ratio, triple(e.magnitude_pct), triple(e.axis_pct[0]),
                     triple(e.axis_pct[1]), triple(e.axis_pct[2]), triple(e.vector_pct));
}

// An estimate's resultants against the recorded ones, frame by frame.
ResultantErrors CompareResultants(const std::vector<Eigen::Vector3d>& estimated,
                                  const std::vector<Eigen::Vector3d>& recorded) {
  ResultantErrors e;
  if (estimated.empty()) return e;
  std::array<std::vector<double>, 3> axis;
  std::vector<double> magnitude, vector, ratio;
  std::array<std::vector<double>, 3> components;
  for (size_t k = 0; k < estimated.size(); ++k) {
    const Eigen::Vector3d& f = estimated[k];
    const Eigen::Vector3d& r = recorded[k];
    const double scale = 100.0 / r.norm();
    for (int a = 0; a < 3; ++a) {
      axis[a].push_back(std::abs(f(a) - r(a)) * scale);
      components[a].push_back(f(a));
    }
    magnitude.push_back(std::abs(f.norm() - r.norm()) * scale);
    vector.push_back((f - r).norm() * scale);
    ratio.push_back(f.norm() / r.norm());
  }
  for (int a = 0; a < 3; ++a) {
    e.axis_pct[a] = ErrorSummary::Of(axis[a]);
    e.median_resultant_n(a) = ErrorSummary::Of(components[a]).median;
  }
  e.magnitude_pct = ErrorSummary::Of(magnitude);
  e.vector_pct = ErrorSummary::Of(vector);
  e.median_magnitude_ratio = ErrorSummary::Of(ratio).median;
  return e;
}

// A frame's D in the paper's ordering (dx^1..dx^N, dy^1..dy^N, dz^1..dz^N).
Eigen::VectorXd PaperOrder(const TactileFrame& frame) {
  const int n = frame.num_markers();
  Eigen::VectorXd d(3 * n);
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) d[a * n + i] = frame.displacements_mm[i][a];
  }
  return d;
}

}  // namespace

void VendorForceOptions::Validate() const {
  gel.Validate();
  if (!(min_resultant_n >= 0.0)) {
    throw Error(fmt::format("VendorForceOptions.min_resultant_n must be >= 0, got {}", min_resultant_n));
  }
  if (!(discrepancy_factor >= 1.0)) {
    throw Error(fmt::format("VendorForceOptions.discrepancy_factor must be >= 1, got {}", discrepancy_factor));
  }
}

namespace {

// The frames a force comparison takes, as `tac3d run --recompute-forces` reads them: the recorded
// markers of each frame whose recorded |resultant| is over the limit and whose every value is
// finite, with the recorded resultant and the sum of the vendor's per-marker forces.
struct ComparedFrames {
  std::vector<TactileFrame> frames;
  std::vector<Eigen::Vector3d> recorded, marker_sums;
  int not_finite = 0;  // over the limit but holding a NaN or an infinity: left out
};

ComparedFrames SelectComparedFrames(const SensorConfig& config, const VendorRecording& recording,
                                    double min_resultant_n) {
  const int n = config.markers.rows * config.markers.cols;
  if (recording.markers() != n) {
    throw Error(fmt::format("the recording has {} markers, the config {}", recording.markers(), n));
  }
  ComparedFrames c;
  const std::vector<double> times_s = recording.send_timestamp.Float64Values();
  for (std::int64_t k = 0; k < recording.frames(); ++k) {
    const Eigen::Vector3d resultant = VendorRecording::Frame(recording.resultant_force, k).row(0).transpose();
    if (!(resultant.norm() > min_resultant_n)) continue;
    if (!resultant.allFinite() || recording.FirstNonFiniteMarker(k) >= 0) {
      ++c.not_finite;
      continue;
    }
    c.recorded.push_back(resultant);
    c.marker_sums.push_back(VendorRecording::Frame(recording.forces, k).colwise().sum().transpose());
    TactileFrame frame = TactileFrame::Sized(config.markers.rows, config.markers.cols);
    frame.index = k;
    frame.timestamp_s = times_s[k];
    const Eigen::MatrixX3d positions = VendorRecording::Frame(recording.positions, k);
    const Eigen::MatrixX3d displacements = VendorRecording::Frame(recording.displacements, k);
    for (int i = 0; i < n; ++i) {
      frame.valid[i] = true;
      frame.positions_mm[i] = positions.row(i).transpose();
      frame.displacements_mm[i] = displacements.row(i).transpose();
    }
    c.frames.push_back(std::move(frame));
  }
  return c;
}

// `tac3d run`'s options for the sensor, with the inverse the options give.
PipelineOptions RunOptions(const SensorConfig& config, const VendorForceOptions& options) {
  PipelineOptions run = DefaultPipelineOptions(config);
  if (options.weight) run.force.weight = *options.weight;
  if (options.support_resolve) run.force.support_refinement = *options.support_resolve;
  run.Validate();
  return run;
}

fem::ComplianceModel GelModel(const fem::BodyModelOptions& body, const VendorForceOptions& options) {
  return options.cache_dir.empty()
             ? fem::CalcComplianceModel(body, options.show_progress)
             : fem::LoadOrBuildComplianceModel(body, options.cache_dir, options.show_progress).model;
}

// The frames' resultants through the pipeline's own code (Pipeline::RecomputeForces); with
// `support_refined`, how many of them the contact-support re-solve ran on.
std::vector<Eigen::Vector3d> RecomputedResultants(const SensorConfig& config, const fem::ComplianceModel& model,
                                                  const PipelineOptions& options,
                                                  const std::vector<TactileFrame>& frames,
                                                  int* support_refined = nullptr) {
  Pipeline pipeline(config, model.h, model.marker_positions, options);
  std::vector<Eigen::Vector3d> resultants;
  for (TactileFrame frame : frames) {
    pipeline.RecomputeForces(frame);
    resultants.push_back(frame.resultant_force_n);
    if (support_refined) *support_refined += pipeline.force_frame().support_refined ? 1 : 0;
  }
  return resultants;
}

}  // namespace

VendorForceEvaluation EvaluateVendorForces(const SensorConfig& config, const VendorRecording& recording,
                                           const VendorForceOptions& options) {
  options.Validate();
  VendorForceEvaluation f;
  f.options = options;
  f.body = VendorBodyModelOptions(config, options.gel);
  f.gel_description = DescribeVendorGel(f.body, options.gel);
  const PipelineOptions run = RunOptions(config, options);
  f.inverse = run.force;
  const ComparedFrames compared = SelectComparedFrames(config, recording, options.min_resultant_n);
  const fem::ComplianceModel model = GelModel(f.body, options);
  f.compliance = model.provenance;
  const std::vector<TactileFrame>& frames = compared.frames;
  const std::vector<Eigen::Vector3d>& recorded = compared.recorded;
  f.frames_not_finite = compared.not_finite;
  f.frames_compared = static_cast<int>(recorded.size());
  if (recorded.empty()) return f;

  // `tac3d run`'s forces; beside them the same weight with the contact-support re-solve on.
  PipelineOptions with_resolve = run;
  with_resolve.force.support_refinement = true;
  f.tac3d = CompareResultants(RecomputedResultants(config, model, run, frames), recorded);
  f.tac3d_support_resolve = CompareResultants(
      RecomputedResultants(config, model, with_resolve, frames, &f.frames_support_refined), recorded);

  // For reference: F = K D at the weight the discrepancy principle picks for the datasheet's
  // position noise on these frames' displacements (never their forces).
  f.position_noise_mm = config.vendor_camera->datasheet.position_noise_mm;
  DisplacementNoise noise;
  noise.variance_mm2 = f.position_noise_mm.cwiseAbs2();
  std::vector<Eigen::VectorXd> displacements;
  for (const TactileFrame& frame : frames) displacements.push_back(PaperOrder(frame));
  f.discrepancy_weight = SelectRegularizationWeight(
      ComplianceSpectrum(model.h), displacements, noise,
      {.rule = WeightRule::kDiscrepancy, .discrepancy_factor = options.discrepancy_factor});
  PipelineOptions at_discrepancy = run;
  at_discrepancy.force.weight = f.discrepancy_weight.weight;
  at_discrepancy.force.support_refinement = false;
  f.tac3d_discrepancy_weight = CompareResultants(RecomputedResultants(config, model, at_discrepancy, frames), recorded);

  std::array<std::vector<double>, 3> recorded_components;
  for (const Eigen::Vector3d& r : recorded) {
    for (int a = 0; a < 3; ++a) recorded_components[a].push_back(r(a));
  }
  for (int a = 0; a < 3; ++a) f.median_recorded_resultant_n(a) = ErrorSummary::Of(recorded_components[a]).median;
  f.vendor_marker_sum = CompareResultants(compared.marker_sums, recorded);
  return f;
}

VendorGainCalibration CalibrateGainsOnVendorRecording(const SensorConfig& config, const VendorRecording& recording,
                                                      const VendorForceOptions& options,
                                                      ForceGainFitOptions fit_options) {
  options.Validate();
  fit_options.on_poor_fit = PoorGainFit::kLeaveAtOne;
  fit_options.Validate();
  VendorGainCalibration c;
  const PipelineOptions run = RunOptions(config, options);
  c.inverse = run.force;
  const ComparedFrames compared = SelectComparedFrames(config, recording, options.min_resultant_n);
  c.frames_compared = static_cast<int>(compared.frames.size());
  c.frames_not_finite = compared.not_finite;
  if (c.frames_compared < kMinForcePairs) {
    throw Error(fmt::format("{} frame(s) of the recording hold a recorded |resultant| over {} N (and finite values); "
                            "fitting gains needs at least {}",
                            c.frames_compared, options.min_resultant_n, kMinForcePairs));
  }
  const fem::ComplianceModel model = GelModel(VendorBodyModelOptions(config, options.gel), options);
  const std::vector<Eigen::Vector3d> measured =
      RecomputedResultants(config, model, run, compared.frames);
  std::vector<ForcePair> pairs;
  for (size_t k = 0; k < measured.size(); ++k) pairs.push_back({.measured_n = measured[k], .reference_n = compared.recorded[k]});
  c.fit = FitForceGains(pairs, fit_options);
  return c;
}

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
  if (forces) {
    const VendorForceEvaluation& f = *forces;
    text += f.gel_description + "\n";
    text += fmt::format("compliance: {} nodes, {} elements, {} free DOFs\n", f.compliance.num_nodes,
                        f.compliance.num_elements, f.compliance.num_free_dofs);
    text += fmt::format("{} frames with the recorded |resultant| over {} N", f.frames_compared,
                        f.options.min_resultant_n);
    if (f.frames_not_finite > 0) {
      text += fmt::format(" ({} more left out: a NaN or an infinity in a marker or the resultant)",
                          f.frames_not_finite);
    }
    if (f.frames_compared > 0) {
      const Eigen::Vector3d& r = f.median_recorded_resultant_n;
      text += fmt::format(" (median ({:.3f}, {:.3f}, {:.3f}) N)\n", r.x(), r.y(), r.z());
      text += fmt::format("inverse: tac3d run's for this sensor{}: Tikhonov weight {:.4g} (mm/N)^2, contact-support "
                          "re-solve {}, no gains\n",
                          f.options.weight || f.options.support_resolve ? " with the options given" : " (its defaults)",
                          f.inverse.weight, f.inverse.support_refinement ? "on" : "off");
      text += FormatResultantErrors("tac3d's forces", f.tac3d);
      text += FormatResultantErrors(fmt::format("the same weight, with the contact-support re-solve (ran on {} of {} "
                                                "frames)",
                                                f.frames_support_refined, f.frames_compared),
                                    f.tac3d_support_resolve);
      text += FormatResultantErrors(
          fmt::format("F = K D at the discrepancy principle's weight {:.4g} (mm/N)^2 for the datasheet's position noise "
                      "{:.4f} / {:.4f} / {:.4f} mm",
                      f.discrepancy_weight.weight, f.position_noise_mm.x(), f.position_noise_mm.y(),
                      f.position_noise_mm.z()),
          f.tac3d_discrepancy_weight);
      text += FormatResultantErrors("vendor's per-marker forces summed (reference)", f.vendor_marker_sum);
    } else {
      text += "\n";
    }
  }
  return text + fmt::format("all pass: {}\n", all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const VendorEvaluation& e) {
  nlohmann::json acceptance = nlohmann::json::object();
  for (const EvalCheck& check : e.checks) acceptance[check.name] = check.tolerance;
  const Eigen::Vector3d& axis = e.reference_position_median_abs_error_mm;
  nlohmann::json json = {{"checks", ToJson(e.checks)},
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
  if (e.forces) json.update(Json(*e.forces));
  return json;
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
  if (const std::int64_t lost = recording.FirstNonFiniteMarker(options.reference_frame); lost >= 0) {
    throw Error(fmt::format("reference frame {}: marker {}'s position, displacement or force is not a finite "
                            "number; choose another --reference-frame",
                            options.reference_frame, lost));
  }
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
  if (options.forces) {
    e.forces = EvaluateVendorForces(config, recording, *options.forces);
    constexpr const char* kName = "resultant_magnitude_error_median_pct";
    e.checks.push_back(e.forces->frames_compared > 0
                           ? EvalCheck::AtMost(kName, e.forces->tac3d.magnitude_pct.median, 10.0, "%")
                           : EvalCheck::NotApplicable(kName, 10.0, EvalCheck::Bound::kAtMost, "%"));
  }
  e.all_pass = AllPass(e.checks);
  return e;
}

}  // namespace tac3d
