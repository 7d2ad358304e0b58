#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tac3d/calib/calibration_board.h"
#include "tac3d/calib/virtual_stereo_calibration.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d {

/// How a built sensor differs from its design: every draw uniform within the bound, from
/// `seed`. The defaults are a small wide-angle lens and a careful assembly.
struct SensorPerturbationOptions {
  std::uint64_t seed = 1;
  double focal_error_max = 0.01;          ///< fx, fy scaled by 1 + e, |e| <= this
  double principal_point_error_max_px = 3.0;  ///< cx, cy each off by up to this
  double k1_min = -0.12;                  ///< barrel distortion of a small wide-angle lens
  double k1_max = -0.05;
  double k2_max = 0.05;                   ///< k2 in [0, k2_max]
  double tangential_max = 5e-4;           ///< |p1|, |p2|
  double mirror_tilt_max_deg = 0.3;       ///< each mirror turned about an axis in its plane
  double mirror_shift_max_mm = 0.2;       ///< each mirror moved by a vector this long at most
  /// The camera turned about a random axis by up to this and moved by a vector this long at
  /// most (0 by default: the calibration figures of docs/calibration.md predate them;
  /// ManufacturingSpread() sets the tolerances).
  double camera_tilt_max_deg = 0.0;
  double camera_shift_max_mm = 0.0;

  /// Sensor-to-sensor spread at general machining tolerances (ISO 2768-1 class m:
  /// +-0.3 mm on 30-120 mm, +-0.5 deg on legs of 10-50 mm) for the camera's mount, the
  /// mirrors as the defaults; docs/render.md, "Session conditions".
  static SensorPerturbationOptions ManufacturingSpread(std::uint64_t seed);

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// The twin's "true" sensor for calibration work: `nominal` with the camera's intrinsics
/// and the four mirrors perturbed as a real build is, and the virtual cameras recomputed
/// from the perturbed mirrors (OpticalLayout::SensorFromVirtualCamera) with the perturbed
/// intrinsics, so they are the truth a calibration should recover. Column ranges kept.
/// @throws Error if `nominal` has no mirrors or virtual cameras, or the options are invalid.
SensorConfig PerturbSensor(const SensorConfig& nominal, const SensorPerturbationOptions& options);

/// The most random views a calibration set has: fifty times the default, far more than a
/// calibration gains from, and what `tac3d calibrate` loads at once (1000 images of 640 x 480
/// are 300 MB).
inline constexpr int kMaxCalibrationViews = 1000;

struct CalibrationSetOptions {
  int views = 20;  ///< random board poses, besides the reference view: 1 .. kMaxCalibrationViews
  std::uint64_t seed = 1;
  CalibrationBoard board;
  double position_range_mm = 3.0;  ///< board centre x, y, z each within +- this of the origin
  double max_tilt_deg = 20.0;      ///< tilt of the board's normal off the sensor's z axis
  double max_spin_deg = 10.0;      ///< turn of the board about its normal
  /// Every dot's image must stay this far inside its half's columns and the image.
  double edge_margin_px = 12.0;
  RenderOptions render;            ///< noise seed: render.seed; frame index: the view's
  bool progress = false;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// Rendered views of the board: the reference view (first, "reference.png") and the random
/// ones ("view_NN.png"), with the board's true pose in each.
struct CalibrationSet {
  CalibrationBoardFile board_file;
  std::vector<CalibrationImage> images;
  std::vector<Rigid3> sensor_from_board;  ///< the true pose in each image
};

/// Renders a calibration set through `truth`'s mirrors (BoardImageRenderer, no elastic
/// body). Random poses are drawn until the whole grid is seen in both halves.
/// @throws Error if the options are invalid, or no pose is seen whole within 1000 draws.
CalibrationSet RenderCalibrationSet(const SensorConfig& truth, const CalibrationSetOptions& options);

/// As above, handing each image to `sink` as soon as it is rendered instead of keeping it: the
/// set returned has no images, so memory does not grow with the number of views.
/// @throws Error as above, and whatever `sink` throws (the images after it are not rendered).
CalibrationSet RenderCalibrationSet(const SensorConfig& truth,
                                    const CalibrationSetOptions& options,
                                    const std::function<void(const CalibrationImage&)>& sink);

/// Renders a calibration set and writes it as it goes, in the folder layout `tac3d calibrate`
/// reads: each image as PNG once rendered, then board.yaml and truth.yaml (the true sensor, for
/// evaluation only). The folder is created first.
/// @return the set, without its images.
/// @throws Error as RenderCalibrationSet does, or if the folder or a file cannot be written.
CalibrationSet WriteCalibrationSet(const SensorConfig& truth,
                                   const CalibrationSetOptions& options,
                                   const std::string& dir);


}  // namespace tac3d
