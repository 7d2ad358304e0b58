#include "tac3d/eval/marker_evaluation.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

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
// A motion is applied over this many frames, as a press or a slide is, so the tracker sees
// at most a third of it between two frames.
constexpr int kMotionSteps = 3;
constexpr double kPositionAcceptanceMm = 0.02;
constexpr double kDisplacementAcceptanceMm = 0.01;

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

nlohmann::json ToJson(const ModelStats& s) {
  return {{"position_rmse_mm", s.position.rms()},
          {"position_max_mm", s.position.max},
          {"displacement_rmse_mm", s.displacement.rms()},
          {"displacement_max_mm", s.displacement.max}};
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

nlohmann::json EvaluateMarkers(const MarkerEvaluationOptions& options) {
  options.Validate();
  SensorConfig truth, measured;
  nlohmann::json calibration_json = nullptr;
  if (options.calibrate) {
    const TwinCalibration twin = CalibrateInTwin(options.calibration);
    truth = twin.truth;
    measured = twin.calibrated;
    calibration_json = {{"seed", options.calibration.seed},
                        {"reprojection_rms_px", twin.calibration.summary.rms_px}};
  } else {
    truth = measured = DefaultSensorConfig();
  }
  RenderOptions render;
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
  nlohmann::json motions = nlohmann::json::array();
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
    nlohmann::json by_model;
    for (size_t m = 0; m < kModels.size(); ++m) {
      references[m].Apply(fields[m]);
      AddPositionErrors(fields[m], moved, stats[m].position);
      for (size_t i = 0; i < rest.size(); ++i) {
        if (fields[m].valid[i]) stats[m].displacement.Add(fields[m].displacements[i] - (moved[i] - rest[i]));
      }
      total[m].position.Add(stats[m].position);
      total[m].displacement.Add(stats[m].displacement);
      by_model[kModelNames[m]] = ToJson(stats[m]);
    }
    const int valid = fields[kPolynomial].CountValid();
    min_valid = std::min(min_valid, valid);
    motions.push_back({{"name", motion.name}, {"valid_markers", valid}, {"by_model", by_model}});
  }

  nlohmann::json by_model, undeformed_json;
  for (size_t m = 0; m < kModels.size(); ++m) {
    by_model[kModelNames[m]] = ToJson(total[m]);
    undeformed_json[kModelNames[m]] = undeformed[m].position.rms();
  }
  const double position = total[kPolynomial].position.rms();
  const double displacement = total[kPolynomial].displacement.rms();
  return {{"position_rmse_mm", position},
          {"displacement_rmse_mm", displacement},
          {"by_model", by_model},
          {"undeformed_position_rmse_mm", undeformed_json},
          {"motions", motions},
          {"markers", rest.size()},
          {"min_valid_markers", min_valid},
          {"reference_frames", options.reference_frames},
          {"calibrated", options.calibrate},
          {"calibration", calibration_json},
          {"acceptance", {{"position_rmse_mm", kPositionAcceptanceMm},
                          {"displacement_rmse_mm", kDisplacementAcceptanceMm}}},
          {"pass", position <= kPositionAcceptanceMm && displacement <= kDisplacementAcceptanceMm}};
}

}  // namespace tac3d
