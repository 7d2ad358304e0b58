#include "tac3d/eval/calibration_evaluation.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "tac3d/calib/dot_grid_detector.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/stereo/stereo_rig.h"
#include "tac3d/twin/calibration_set.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr double kReprojectionAcceptancePx = 0.1;
constexpr double kCameraPositionAcceptanceMm = 0.3;
constexpr double kCameraRotationAcceptanceDeg = 0.1;
constexpr double kDotDisplacementAcceptanceMm = 0.01;

nlohmann::json Json(const LeftRight& figure) {
  return {{"left", figure.left}, {"right", figure.right}, {"max", figure.max()}};
}

std::string Format(const LeftRight& figure, const char* unit) {
  return fmt::format("left {:.4g} {}, right {:.4g} {}", figure.left, unit, figure.right, unit);
}

// {check name: tolerance}.
nlohmann::json Acceptance(const std::vector<EvalCheck>& checks) {
  nlohmann::json json = nlohmann::json::object();
  for (const EvalCheck& check : checks) json[check.name] = check.tolerance;
  return json;
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

std::string CalibrationEvaluation::Report() const {
  std::string text = FormatChecks(checks);
  text += fmt::format("views used: {} of {} images ({} refused)\n", summary.views_used,
                      summary.images, summary.views_refused);
  text += fmt::format("camera position error: {}\n", Format(camera_position_error_mm, "mm"));
  text += fmt::format("camera rotation error: {}\n", Format(camera_rotation_error_deg, "deg"));
  text += fmt::format("nominal design's camera position error: {}\n",
                      Format(nominal_camera_position_error_mm, "mm"));
  text += fmt::format("nominal design's camera rotation error: {}\n",
                      Format(nominal_camera_rotation_error_deg, "deg"));
  text += fmt::format("focal length error: {}\n", Format(focal_length_error_px, "px"));
  text += fmt::format("principal point error: {}\n", Format(principal_point_error_px, "px"));
  return text + fmt::format("all pass: {}\n", all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const CalibrationEvaluation& e) {
  nlohmann::json json = ToJson(e.summary);
  json.update({{"checks", ToJson(e.checks)},
               {"all_pass", e.all_pass},
               {"camera_position_error_mm", Json(e.camera_position_error_mm)},
               {"camera_rotation_error_deg", Json(e.camera_rotation_error_deg)},
               {"focal_length_error_px", Json(e.focal_length_error_px)},
               {"principal_point_error_px", Json(e.principal_point_error_px)},
               {"nominal_camera_position_error_mm", Json(e.nominal_camera_position_error_mm)},
               {"nominal_camera_rotation_error_deg", Json(e.nominal_camera_rotation_error_deg)},
               {"acceptance", Acceptance(e.checks)},
               {"pass", e.all_pass},
               {"calibration_seconds", e.summary.seconds}});
  return json;
}

CalibrationEvaluation EvaluateCalibration(const TwinCalibrationOptions& options) {
  const TwinCalibration twin = CalibrateInTwin(options);
  CalibrationEvaluation e;
  e.summary = twin.calibration.summary;
  auto errors = [&](const SensorConfig& estimate, LeftRight& position, LeftRight& rotation) {
    for (ImageHalf half : kImageHalves) {
      const Rigid3& a = Camera(estimate, half).sensor_from_vcam;
      const Rigid3& b = Camera(twin.truth, half).sensor_from_vcam;
      (half == ImageHalf::kLeft ? position.left : position.right) = (a.translation() - b.translation()).norm();
      (half == ImageHalf::kLeft ? rotation.left : rotation.right) = RotationAngleDeg(a.linear(), b.linear());
    }
  };
  errors(twin.calibrated, e.camera_position_error_mm, e.camera_rotation_error_deg);
  errors(twin.nominal, e.nominal_camera_position_error_mm, e.nominal_camera_rotation_error_deg);
  const CameraIntrinsics& true_camera = twin.truth.camera.intrinsics;
  std::array<double, 2> focal{}, principal{};
  for (int h = 0; h < 2; ++h) {
    const CameraIntrinsics& c = twin.calibration.intrinsics[h];
    focal[h] = std::max(std::abs(c.fx - true_camera.fx), std::abs(c.fy - true_camera.fy));
    principal[h] = std::hypot(c.cx - true_camera.cx, c.cy - true_camera.cy);
  }
  e.focal_length_error_px = {focal[0], focal[1]};
  e.principal_point_error_px = {principal[0], principal[1]};
  e.checks = {
      EvalCheck::AtMost("reprojection_rms_px", e.summary.rms_px, kReprojectionAcceptancePx, "px"),
      EvalCheck::AtMost("camera_position_error_mm", e.camera_position_error_mm.max(),
                        kCameraPositionAcceptanceMm, "mm"),
      EvalCheck::AtMost("camera_rotation_error_deg", e.camera_rotation_error_deg.max(),
                        kCameraRotationAcceptanceDeg, "deg")};
  e.all_pass = AllPass(e.checks);
  return e;
}

std::string DisplacementEvaluation::Report() const {
  std::string text = FormatChecks(checks);
  text += fmt::format("{} dots moved {:.4g} mm along x, y, z from ({:.4g}, {:.4g}, {:.4g}) mm\n",
                      dots_per_move, step_mm, start_mm.x(), start_mm.y(), start_mm.z());
  text += fmt::format("RMSE x / y / z: {:.4g} / {:.4g} / {:.4g} mm; with the true rig {:.4g} / "
                      "{:.4g} / {:.4g} mm\n",
                      rmse_mm.x(), rmse_mm.y(), rmse_mm.z(), rmse_mm_true_rig.x(),
                      rmse_mm_true_rig.y(), rmse_mm_true_rig.z());
  text += fmt::format("calibration reprojection RMS: {:.4g} px\n", calibration_reprojection_rms_px);
  return text + fmt::format("all pass: {}\n", all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const DisplacementEvaluation& e) {
  const auto xyz = [](const Eigen::Vector3d& v) {
    return nlohmann::json{{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
  };
  return {{"checks", ToJson(e.checks)},
          {"all_pass", e.all_pass},
          {"step_mm", e.step_mm},
          {"dots_per_move", e.dots_per_move},
          {"start_mm", {e.start_mm.x(), e.start_mm.y(), e.start_mm.z()}},
          {"rmse_mm", xyz(e.rmse_mm)},
          {"rmse_mm_true_rig", xyz(e.rmse_mm_true_rig)},
          {"calibration_reprojection_rms_px", e.calibration_reprojection_rms_px},
          {"acceptance_mm", kDotDisplacementAcceptanceMm},
          {"pass", e.all_pass}};
}

DisplacementEvaluation EvaluateDisplacement(const DisplacementEvaluationOptions& options) {
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

  DisplacementEvaluation e;
  e.step_mm = options.step_mm;
  e.start_mm = options.start_mm;
  e.dots_per_move = board.rows * board.cols;
  e.calibration_reprojection_rms_px = twin.calibration.summary.rms_px;
  for (int r = 0; r < 2; ++r) {
    Eigen::Vector3d& rmse = r == 0 ? e.rmse_mm : e.rmse_mm_true_rig;
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector3d truth = centres[axis + 1] - centres[axis];
      double sum = 0;
      const auto& before = measured[r][axis];
      const auto& after = measured[r][axis + 1];
      for (size_t i = 0; i < before.size(); ++i) sum += (after[i] - before[i] - truth).squaredNorm();
      rmse[axis] = std::sqrt(sum / before.size());
    }
  }
  const char* names[] = {"rmse_x_mm", "rmse_y_mm", "rmse_z_mm"};
  for (int axis = 0; axis < 3; ++axis) {
    e.checks.push_back(
        EvalCheck::AtMost(names[axis], e.rmse_mm[axis], kDotDisplacementAcceptanceMm, "mm"));
  }
  e.all_pass = AllPass(e.checks);
  return e;
}

}  // namespace tac3d
