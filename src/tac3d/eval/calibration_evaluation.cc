#include "tac3d/eval/calibration_evaluation.h"

#include <algorithm>
#include <cmath>

#include "tac3d/calib/dot_grid_detector.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/stereo/stereo_rig.h"
#include "tac3d/twin/calibration_set.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Left, right and the worse of the two.
nlohmann::json LeftRightMax(double left, double right) {
  return {{"left", left}, {"right", right}, {"max", std::max(left, right)}};
}

const VirtualCameraConfig& Camera(const SensorConfig& config, ImageHalf half) {
  for (const VirtualCameraConfig& v : config.virtual_cameras) {
    if (v.half == half) return v;
  }
  TAC3D_DEMAND(false);
}

}  // namespace

void TwinCalibrationOptions::Validate() const {
  if (views < 15) {
    throw Error(fmt::format("twin calibration: views = {} must be >= 15", views));
  }
  board.Validate();
}

void DisplacementEvaluationOptions::Validate() const {
  calibration.Validate();
  if (!(step_mm > 0 && step_mm <= 5)) {
    throw Error(fmt::format("displacement evaluation: step_mm = {} must be in (0, 5]", step_mm));
  }
  if (!start_mm.allFinite()) throw Error("displacement evaluation: start_mm must be finite");
}

TwinCalibration CalibrateInTwin(const TwinCalibrationOptions& options) {
  options.Validate();
  TwinCalibration out;
  out.nominal = DefaultSensorConfig();
  SensorPerturbationOptions perturbation;
  perturbation.seed = options.seed;
  out.truth = PerturbSensor(out.nominal, perturbation);
  CalibrationSetOptions set_options;
  set_options.views = options.views;
  set_options.seed = options.seed;
  set_options.board = options.board;
  set_options.render.seed = options.seed;
  set_options.progress = options.progress;
  const CalibrationSet set = RenderCalibrationSet(out.truth, set_options);
  VirtualStereoCalibrationOptions calibration_options;
  calibration_options.progress = options.progress;
  out.calibration = CalibrateVirtualStereo(set.images, set.board_file, out.nominal, calibration_options);
  out.calibrated = out.calibration.ApplyTo(out.nominal);
  return out;
}

nlohmann::json EvaluateCalibration(const TwinCalibrationOptions& options) {
  const TwinCalibration twin = CalibrateInTwin(options);
  const VirtualStereoCalibration::Summary& s = twin.calibration.summary;
  auto errors = [&](const SensorConfig& estimate) {
    std::array<double, 2> position{}, rotation{};
    for (ImageHalf half : kImageHalves) {
      const Rigid3& a = Camera(estimate, half).sensor_from_vcam;
      const Rigid3& b = Camera(twin.truth, half).sensor_from_vcam;
      position[static_cast<int>(half)] = (a.translation() - b.translation()).norm();
      rotation[static_cast<int>(half)] = RotationAngleDeg(a.linear(), b.linear());
    }
    return std::pair{LeftRightMax(position[0], position[1]), LeftRightMax(rotation[0], rotation[1])};
  };
  const auto [position, rotation] = errors(twin.calibrated);
  const auto [nominal_position, nominal_rotation] = errors(twin.nominal);
  const CameraIntrinsics& true_camera = twin.truth.camera.intrinsics;
  std::array<double, 2> focal{}, principal{};
  for (int h = 0; h < 2; ++h) {
    const CameraIntrinsics& c = twin.calibration.intrinsics[h];
    focal[h] = std::max(std::abs(c.fx - true_camera.fx), std::abs(c.fy - true_camera.fy));
    principal[h] = std::hypot(c.cx - true_camera.cx, c.cy - true_camera.cy);
  }
  const bool pass = s.rms_px <= 0.1 && position["max"].get<double>() <= 0.3 &&
                    rotation["max"].get<double>() <= 0.1;
  return {{"images", s.images},
          {"views_used", s.views_used},
          {"views_refused", s.views_refused},
          {"reprojection_rms_px", s.rms_px},
          {"mono_rms_px", {s.mono_rms_px[0], s.mono_rms_px[1]}},
          {"reference_rms_px", s.reference_rms_px},
          {"camera_position_error_mm", position},
          {"camera_rotation_error_deg", rotation},
          {"focal_length_error_px", LeftRightMax(focal[0], focal[1])},
          {"principal_point_error_px", LeftRightMax(principal[0], principal[1])},
          {"nominal_camera_position_error_mm", nominal_position},
          {"nominal_camera_rotation_error_deg", nominal_rotation},
          {"acceptance",
           {{"reprojection_rms_px", 0.1}, {"camera_position_error_mm", 0.3},
            {"camera_rotation_error_deg", 0.1}}},
          {"pass", pass},
          {"calibration_seconds", s.seconds}};
}

nlohmann::json EvaluateDisplacement(const DisplacementEvaluationOptions& options) {
  options.Validate();
  const TwinCalibration twin = CalibrateInTwin(options.calibration);
  const CalibrationBoard& board = options.calibration.board;
  RenderOptions render;
  render.seed = options.calibration.seed + 1;  // other noise than the calibration set's
  const BoardImageRenderer renderer(twin.truth, render);
  const DotBoard dot_board = DotBoard{board};

  // Paper V.A: start, then 3 mm along x, then along y, then along z.
  std::vector<Eigen::Vector3d> centres = {options.start_mm};
  for (int axis = 0; axis < 3; ++axis) centres.push_back(centres.back() + options.step_mm * Eigen::Vector3d::Unit(axis));

  const std::array<StereoRig, 2> rigs = {StereoRig::FromSensorConfig(twin.calibrated, false),
                                         StereoRig::FromSensorConfig(twin.truth, false)};
  // Triangulated dots of each pose, per rig.
  std::array<std::vector<std::vector<Eigen::Vector3d>>, 2> measured;
  for (size_t pose = 0; pose < centres.size(); ++pose) {
    const cv::Mat image = renderer.Render(dot_board, dot_board.SensorFromBoard(centres[pose]), pose);
    std::array<DotGridDetection, 2> detections;
    for (const VirtualCameraConfig& v : twin.nominal.virtual_cameras) {
      const cv::Rect roi(v.column_begin, 0, v.column_end - v.column_begin, image.rows);
      detections[static_cast<int>(v.half)] = DetectDotGrid(image, roi, board);
      if (!detections[static_cast<int>(v.half)].found) {
        throw Error(fmt::format("displacement evaluation: board not found in the {} half at "
                                "pose {} (centre {:.2f}, {:.2f}, {:.2f} mm)",
                                ToString(v.half), pose, centres[pose].x(), centres[pose].y(),
                                centres[pose].z()));
      }
    }
    for (int r = 0; r < 2; ++r) {
      std::vector<Eigen::Vector3d> points;
      for (size_t i = 0; i < detections[0].centers.size(); ++i) {
        const Triangulation t =
            TriangulateMidpoint(rigs[r], detections[0].centers[i], detections[1].centers[i]);
        if (!t.valid) {
          throw Error(fmt::format("displacement evaluation: dot {} at pose {} does not triangulate "
                                  "(the {} rig's rays do not meet in front of it)",
                                  i, pose, r == 0 ? "calibrated" : "true"));
        }
        points.push_back(t.point);
      }
      measured[r].push_back(std::move(points));
    }
  }

  std::array<nlohmann::json, 2> rmse;
  bool pass = true;
  const char* axes[] = {"x", "y", "z"};
  for (int r = 0; r < 2; ++r) {
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector3d truth = centres[axis + 1] - centres[axis];
      double sum = 0;
      const auto& before = measured[r][axis];
      const auto& after = measured[r][axis + 1];
      for (size_t i = 0; i < before.size(); ++i) sum += (after[i] - before[i] - truth).squaredNorm();
      const double value = std::sqrt(sum / before.size());
      rmse[r][axes[axis]] = value;
      if (r == 0) pass = pass && value <= 0.01;
    }
  }
  return {{"step_mm", options.step_mm},
          {"dots_per_move", board.rows * board.cols},
          {"start_mm", {options.start_mm.x(), options.start_mm.y(), options.start_mm.z()}},
          {"rmse_mm", rmse[0]},
          {"rmse_mm_true_rig", rmse[1]},
          {"calibration_reprojection_rms_px", twin.calibration.summary.rms_px},
          {"acceptance_mm", 0.01},
          {"pass", pass}};
}

}  // namespace tac3d
