#include "tac3d/eval/marker_evaluation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tac3d/design/light_path_design.h"
#include "tac3d/stereo/marker_field.h"
#include "tac3d/tracking/marker_tracker.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr std::array<RefractionModel, 3> kModels = {RefractionModel::kNone, RefractionModel::kPolynomial,
                                                   RefractionModel::kExact};
constexpr std::array<const char*, 3> kModelNames = {"none", "polynomial", "exact"};
constexpr int kPolynomial = 1;
static_assert(kModels[0] == RefractionModel::kNone && kModels[kPolynomial] == RefractionModel::kPolynomial &&
              kModels[2] == RefractionModel::kExact);  // the order Of() and kModelNames assume
// A motion is applied over this many frames, as a press or a slide is, so the tracker sees
// at most a third of it between two frames.
constexpr int kMotionSteps = 3;
constexpr double kMarkerPositionAcceptanceMm = 0.02;
constexpr double kMarkerDisplacementAcceptanceMm = 0.01;

// RMS and maximum of error-vector lengths.
struct ErrorStats {
  double sum_squares = 0.0;
  double max = 0.0;
  int count = 0;

  void Add(const Eigen::Vector3d& error) {
    const double e = error.norm();
    sum_squares += e * e;
    max = std::max(max, e);
    ++count;
  }
  void Add(const ErrorStats& other) {
    sum_squares += other.sum_squares;
    max = std::max(max, other.max);
    count += other.count;
  }
  double rms() const { return count > 0 ? std::sqrt(sum_squares / count) : NAN; }
};

struct ModelStats {
  ErrorStats position, displacement;
};

MarkerErrors Errors(const ModelStats& s) {
  return {s.position.rms(), s.position.max, s.displacement.rms(), s.displacement.max};
}

// The figure of model kModels[m].
template <typename T>
T& Of(PerRefractionModel<T>& figures, size_t m) {
  return m == 0 ? figures.none : m == 1 ? figures.polynomial : figures.exact;
}
template <typename T>
const T& Of(const PerRefractionModel<T>& figures, size_t m) {
  return m == 0 ? figures.none : m == 1 ? figures.polynomial : figures.exact;
}

nlohmann::json Json(const MarkerErrors& e) {
  return {{"position_rmse_mm", e.position_rmse_mm},
          {"position_max_mm", e.position_max_mm},
          {"displacement_rmse_mm", e.displacement_rmse_mm},
          {"displacement_max_mm", e.displacement_max_mm}};
}

// {model name: Json(figure)} or {model name: figure}.
template <typename T>
nlohmann::json Json(const PerRefractionModel<T>& figures) {
  nlohmann::json json;
  for (size_t m = 0; m < kModels.size(); ++m) {
    if constexpr (std::is_same_v<T, MarkerErrors>) {
      json[kModelNames[m]] = Json(Of(figures, m));
    } else {
      json[kModelNames[m]] = Of(figures, m);
    }
  }
  return json;
}

std::vector<Eigen::Vector3d> Interpolate(const std::vector<Eigen::Vector3d>& from,
                                         const std::vector<Eigen::Vector3d>& to, double t) {
  std::vector<Eigen::Vector3d> out(from.size());
  for (size_t i = 0; i < from.size(); ++i) out[i] = from[i] + t * (to[i] - from[i]);
  return out;
}

// Tracks one frame and triangulates it with every model.
class Measurement {
 public:
  explicit Measurement(const SensorConfig& measured) : tracker_(measured) {
    for (size_t m = 0; m < kModels.size(); ++m) {
      MarkerTriangulatorOptions options;
      options.model = kModels[m];
      triangulators_.emplace_back(measured, options);
    }
  }

  void Reset() { tracker_.Reset(); }

  std::array<MarkerField, 3> Measure(const cv::Mat& image, const std::string& what) {
    tracker_.Track(image, observation_);
    const int markers = observation_.rows * observation_.cols;
    if (observation_.summary.paired_markers < markers / 2) {
      throw Error(fmt::format("eval markers: {}: only {} of {} markers seen in both halves", what,
                              observation_.summary.paired_markers, markers));
    }
    std::array<MarkerField, 3> fields;
    for (size_t m = 0; m < kModels.size(); ++m) {
      triangulators_[m].Triangulate(observation_.half(ImageHalf::kLeft).uv,
                                    observation_.half(ImageHalf::kRight).uv, fields[m]);
    }
    return fields;
  }

 private:
  MarkerTracker tracker_;
  std::vector<MarkerTriangulator> triangulators_;
  MarkerObservation observation_;
};

void AddPositionErrors(const MarkerField& field, const std::vector<Eigen::Vector3d>& truth,
                       ErrorStats& stats) {
  for (size_t i = 0; i < truth.size(); ++i) {
    if (field.valid[i]) stats.Add(field.positions[i] - truth[i]);
  }
}

}  // namespace

void MarkerEvaluationOptions::Validate() const {
  if (calibrate) calibration.Validate();
  if (motions.empty()) throw Error("marker evaluation: motions must not be empty");
  if (reference_frames < 1 || reference_frames > 100) {
    throw Error(fmt::format("marker evaluation: reference_frames = {} must be in [1, 100]",
                            reference_frames));
  }
}

std::string MarkerEvaluation::Report() const {
  std::string text = FormatChecks(checks);
  for (size_t m = 0; m < kModels.size(); ++m) {
    const MarkerErrors& errors = Of(by_model, m);
    text += fmt::format("refraction {:<10} position RMSE {:.4f} mm (max {:.4f}), displacement RMSE "
                        "{:.4f} mm (max {:.4f}); undeformed position RMSE {:.4f} mm\n",
                        kModelNames[m], errors.position_rmse_mm, errors.position_max_mm,
                        errors.displacement_rmse_mm, errors.displacement_max_mm,
                        Of(undeformed_position_rmse_mm, m));
  }
  text += fmt::format("valid markers: at least {} of {} in every motion\n", min_valid_markers, markers);
  if (real_image_nuisances) {
    const RenderOptions real = RenderOptions{}.WithRealImageNuisances();
    text += fmt::format("real-image nuisances: coloured uneven LEDs, blur {:.1f} px, JPEG quality {}\n",
                        real.blur_sigma_px, real.jpeg_quality);
  }
  if (calibration) {
    text += fmt::format("calibrated rig: seed {}, reprojection RMS {:.4g} px\n", calibration_seed,
                        calibration->rms_px);
  } else {
    text += "known sensor: no calibration\n";
  }
  return text + fmt::format("all pass: {}\n", all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const MarkerEvaluation& e) {
  nlohmann::json motions = nlohmann::json::array();
  for (const MarkerMotionErrors& motion : e.motions) {
    motions.push_back(
        {{"name", motion.name}, {"valid_markers", motion.valid_markers}, {"by_model", Json(motion.by_model)}});
  }
  nlohmann::json acceptance = nlohmann::json::object();
  for (const EvalCheck& check : e.checks) acceptance[check.name] = check.tolerance;
  nlohmann::json calibration = nullptr;
  if (e.calibration) {
    calibration = {{"seed", e.calibration_seed}, {"reprojection_rms_px", e.calibration->rms_px}};
  }
  return {{"checks", ToJson(e.checks)},
          {"all_pass", e.all_pass},
          {"position_rmse_mm", e.by_model.polynomial.position_rmse_mm},
          {"displacement_rmse_mm", e.by_model.polynomial.displacement_rmse_mm},
          {"by_model", Json(e.by_model)},
          {"undeformed_position_rmse_mm", Json(e.undeformed_position_rmse_mm)},
          {"motions", motions},
          {"markers", e.markers},
          {"min_valid_markers", e.min_valid_markers},
          {"reference_frames", e.reference_frames},
          {"real_image_nuisances", e.real_image_nuisances},
          {"calibrated", e.calibration.has_value()},
          {"calibration", calibration},
          {"acceptance", acceptance},
          {"pass", e.all_pass}};
}

MarkerEvaluation EvaluateMarkers(const MarkerEvaluationOptions& options) {
  options.Validate();
  MarkerEvaluation e;
  SensorConfig truth, measured;
  if (options.calibrate) {
    const TwinCalibration twin = CalibrateInTwin(options.calibration);
    truth = twin.truth;
    measured = twin.calibrated;
    e.calibration_seed = options.calibration.seed;
    e.calibration = twin.calibration.summary;
  } else {
    truth = measured = DefaultSensorConfig();
  }
  RenderOptions render;
  if (options.real_image_nuisances) render = render.WithRealImageNuisances();
  render.seed = options.render_seed;
  const MarkerImageRenderer renderer(truth, render);
  Measurement measurement(measured);
  const std::vector<Eigen::Vector3d> rest = truth.MarkerPositions();
  std::uint64_t frame_index = 0;

  // The reference: undeformed frames with independent noise.
  std::array<ModelStats, 3> undeformed;
  std::array<std::vector<MarkerField>, 3> reference_fields;
  for (int k = 0; k < options.reference_frames; ++k) {
    const auto fields = measurement.Measure(renderer.Render(rest, frame_index++), "undeformed frame");
    for (size_t m = 0; m < kModels.size(); ++m) {
      AddPositionErrors(fields[m], rest, undeformed[m].position);
      reference_fields[m].push_back(fields[m]);
    }
  }
  std::array<DisplacementReference, 3> references;
  for (size_t m = 0; m < kModels.size(); ++m) references[m].Set(reference_fields[m]);

  std::array<ModelStats, 3> total = undeformed;
  int min_valid = static_cast<int>(rest.size());
  for (const MarkerMotion& motion : options.motions) {
    const std::vector<Eigen::Vector3d> moved = motion.Apply(rest);
    // Each motion starts from rest, as a new press does.
    measurement.Reset();
    measurement.Measure(renderer.Render(rest, frame_index++), motion.name + " start");
    std::array<MarkerField, 3> fields;
    for (int step = 1; step <= kMotionSteps; ++step) {
      fields = measurement.Measure(
          renderer.Render(Interpolate(rest, moved, double(step) / kMotionSteps), frame_index++),
          motion.name);
    }
    std::array<ModelStats, 3> stats;
    MarkerMotionErrors& errors = e.motions.emplace_back();
    errors.name = motion.name;
    for (size_t m = 0; m < kModels.size(); ++m) {
      references[m].Apply(fields[m]);
      AddPositionErrors(fields[m], moved, stats[m].position);
      for (size_t i = 0; i < rest.size(); ++i) {
        if (fields[m].valid[i]) stats[m].displacement.Add(fields[m].displacements[i] - (moved[i] - rest[i]));
      }
      total[m].position.Add(stats[m].position);
      total[m].displacement.Add(stats[m].displacement);
      Of(errors.by_model, m) = Errors(stats[m]);
    }
    errors.valid_markers = fields[kPolynomial].CountValid();
    min_valid = std::min(min_valid, errors.valid_markers);
  }

  for (size_t m = 0; m < kModels.size(); ++m) {
    Of(e.by_model, m) = Errors(total[m]);
    Of(e.undeformed_position_rmse_mm, m) = undeformed[m].position.rms();
  }
  e.markers = static_cast<int>(rest.size());
  e.min_valid_markers = min_valid;
  e.reference_frames = options.reference_frames;
  e.real_image_nuisances = options.real_image_nuisances;
  e.checks = {EvalCheck::AtMost("position_rmse_mm", e.by_model.polynomial.position_rmse_mm,
                                kMarkerPositionAcceptanceMm, "mm"),
              EvalCheck::AtMost("displacement_rmse_mm", e.by_model.polynomial.displacement_rmse_mm,
                                kMarkerDisplacementAcceptanceMm, "mm")};
  e.all_pass = AllPass(e.checks);
  return e;
}

}  // namespace tac3d
