#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "tac3d/calib/calibration_board.h"
#include "tac3d/calib/virtual_stereo_calibration.h"
#include "tac3d/sensor/sensor_config.h"

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

/// `tac3d eval calibration`: reprojection_rms_px (the joint stereo calibration), and each
/// recovered virtual camera against the twin's true one: camera_position_error_mm and
/// camera_rotation_error_deg ({left, right, max}), with the nominal design's errors beside
/// them. Acceptance (issue 3): RMS <= 0.1 px, cameras within 0.3 mm and 0.1 deg.
/// @throws Error if the options are invalid or the calibration fails.
nlohmann::json EvaluateCalibration(const TwinCalibrationOptions& options);

struct DisplacementEvaluationOptions {
  TwinCalibrationOptions calibration;
  double step_mm = 3.0;  ///< each move (paper V.A: 3 mm along x, then y, then z)
  /// The board's centre before the first move (sensor frame, mm), flat (no tilt); the moves
  /// keep it within +-step/2 of the origin.
  Eigen::Vector3d start_mm = Eigen::Vector3d(-1.5, -1.5, -1.5);

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// `tac3d eval displacement`: the paper's V.A experiment in the twin. With the rig
/// calibrated from rendered images (CalibrateInTwin), a dot board is moved step_mm along x,
/// then y, then z; each pose's dots are detected in both halves, paired by index and
/// triangulated (TriangulateMidpoint: no gel); each dot's measured displacement is compared
/// with the true move. Reports rmse_mm {x, y, z} (RMS over the dots of the error vector's
/// length), the same with the true rig (detection alone), and the acceptance
/// (<= 0.01 mm on every axis).
/// @throws Error if the options are invalid, the calibration fails or the board is not
/// found in a pose.
nlohmann::json EvaluateDisplacement(const DisplacementEvaluationOptions& options);

}  // namespace tac3d
