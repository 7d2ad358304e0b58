#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include "tac3d/calib/calibration_board.h"
#include "tac3d/calib/virtual_stereo_calibration.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/util/eval_check.h"

namespace tac3d {

/// A calibration in the twin: a perturbed "true" sensor, a rendered set of board views, and
/// the calibration from those images alone, starting from the nominal design.
struct TwinCalibrationOptions {
  int views = 20;          ///< random board poses besides the reference view
  std::uint64_t seed = 1;  ///< the sensor's perturbation, the poses and the camera noise
  CalibrationBoard board;
  bool progress = false;

  /// @throws Error naming the field and the bound (views >= 15, the acceptance).
  void Validate() const;
};

struct TwinCalibration {
  SensorConfig nominal;     ///< the design the calibration starts from
  SensorConfig truth;       ///< what the twin renders
  SensorConfig calibrated;  ///< nominal with the calibrated virtual cameras
  VirtualStereoCalibration calibration;
};

/// @throws Error if the options are invalid or the calibration fails.
TwinCalibration CalibrateInTwin(const TwinCalibrationOptions& options);

/// A figure for each virtual camera and the worse of the two.
struct LeftRight {
  double left = 0.0;
  double right = 0.0;

  double max() const { return left < right ? right : left; }
};

/// What EvaluateCalibration measured: the calibration's summary and each recovered virtual
/// camera against the twin's true one, with the nominal design's errors beside them.
struct CalibrationEvaluation {
  /// In this order (the acceptance): reprojection_rms_px <= 0.1 px (the joint stereo
  /// calibration), camera_position_error_mm <= 0.3 mm and camera_rotation_error_deg
  /// <= 0.1 deg (each the worse of the two cameras).
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  /// Images, views used and refused, the joint, mono and reference RMS, the time.
  VirtualStereoCalibration::Summary summary;
  /// |translation| and rotation angle between the calibrated and the true sensor_from_vcam.
  LeftRight camera_position_error_mm;
  LeftRight camera_rotation_error_deg;
  /// The same for the nominal design the calibration starts from.
  LeftRight nominal_camera_position_error_mm;
  LeftRight nominal_camera_rotation_error_deg;
  /// max(|fx - true fx|, |fy - true fy|) and |principal point - true one| (px).
  LeftRight focal_length_error_px;
  LeftRight principal_point_error_px;

  /// The checks, the figures and the verdict, as the CLI prints them.
  std::string Report() const;
};

/// {"checks", "all_pass", "images", "views_used", "views_refused", "reprojection_rms_px",
///  "mono_rms_px", "reference_rms_px", "camera_position_error_mm",
///  "camera_rotation_error_deg", "focal_length_error_px", "principal_point_error_px",
///  "nominal_camera_position_error_mm", "nominal_camera_rotation_error_deg" (each
///  {"left", "right", "max"}), "acceptance" ({check name: tolerance}), "pass" (= all_pass),
///  "calibration_seconds"}.
nlohmann::json ToJson(const CalibrationEvaluation& evaluation);

/// `tac3d eval calibration`: CalibrateInTwin, then CalibrationEvaluation's figures.
/// @throws Error if the options are invalid or the calibration fails.
CalibrationEvaluation EvaluateCalibration(const TwinCalibrationOptions& options);

struct DisplacementEvaluationOptions {
  TwinCalibrationOptions calibration;
  double step_mm = 3.0;  ///< each move (paper V.A: 3 mm along x, then y, then z)
  /// The board's centre before the first move (sensor frame, mm), flat (no tilt); the moves
  /// keep it within +-step/2 of the origin.
  Eigen::Vector3d start_mm = Eigen::Vector3d(-1.5, -1.5, -1.5);

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// What EvaluateDisplacement measured. Each move's error is the RMS over the dots of the
/// length of (measured displacement - true move).
struct DisplacementEvaluation {
  /// In this order: rmse_x_mm, rmse_y_mm, rmse_z_mm <= 0.01 mm (the calibrated rig; issue
  /// 3's acceptance).
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  /// The move along x, y and z, measured with the calibrated rig (mm).
  Eigen::Vector3d rmse_mm = Eigen::Vector3d::Zero();
  /// The same with the true rig: detection alone (mm).
  Eigen::Vector3d rmse_mm_true_rig = Eigen::Vector3d::Zero();
  /// What was asked: the move and the board's first centre (mm), the dots compared.
  double step_mm = 0.0;
  Eigen::Vector3d start_mm = Eigen::Vector3d::Zero();
  int dots_per_move = 0;
  /// The calibration's joint reprojection RMS (px).
  double calibration_reprojection_rms_px = 0.0;

  /// The checks, the figures and the verdict, as the CLI prints them.
  std::string Report() const;
};

/// {"checks", "all_pass", "step_mm", "dots_per_move", "start_mm" ([x, y, z]), "rmse_mm",
///  "rmse_mm_true_rig" (each {"x", "y", "z"}), "calibration_reprojection_rms_px",
///  "acceptance_mm", "pass" (= all_pass)}.
nlohmann::json ToJson(const DisplacementEvaluation& evaluation);

/// `tac3d eval displacement`: the paper's V.A experiment in the twin. With the rig
/// calibrated from rendered images (CalibrateInTwin), a dot board is moved step_mm along x,
/// then y, then z; each pose's dots are detected in both halves, paired by index and
/// triangulated (TriangulateMidpoint: no gel); each dot's measured displacement is compared
/// with the true move (DisplacementEvaluation says what is checked).
/// @throws Error if the options are invalid, the calibration fails or the board is not
/// found in a pose.
DisplacementEvaluation EvaluateDisplacement(const DisplacementEvaluationOptions& options);

}  // namespace tac3d
