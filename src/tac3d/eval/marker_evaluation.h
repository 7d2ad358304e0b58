#pragma once

#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

#include "tac3d/eval/calibration_evaluation.h"
#include "tac3d/twin/marker_motion.h"

namespace tac3d {

struct MarkerEvaluationOptions {
  /// The rig is calibrated from rendered board images of a perturbed sensor (CalibrateInTwin)
  /// when true; when false the twin renders the designed sensor and the measurement knows it
  /// exactly (tracking and stereo alone, no calibration error: the fast test).
  bool calibrate = true;
  TwinCalibrationOptions calibration;
  /// Known deformations of the marker layer (default: the shear, dent and twist).
  std::vector<MarkerMotion> motions = StandardMarkerMotions();
  /// Undeformed frames (independent noise) averaged into the displacement reference.
  int reference_frames = 5;
  /// Camera noise seed of the rendered marker frames.
  std::uint64_t render_seed = 7;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// `tac3d eval markers`: the marker layer rendered through glass and silicone by the twin,
/// undeformed and under each known motion; tracked (MarkerTracker), triangulated and
/// compensated for refraction (MarkerTriangulator) with each model; compared with the true
/// 3D positions and displacements. Errors are RMS over the valid markers of the 3D error
/// vector's length. Reports per motion and over all frames, for each refraction model
/// ("none", "polynomial", "exact"):
/// {"position_rmse_mm", "displacement_rmse_mm" (both the polynomial model's),
///  "by_model": {model: {"position_rmse_mm", "displacement_rmse_mm", "position_max_mm",
///  "displacement_max_mm"}}, "motions": [...], "valid_markers", "acceptance", "pass"}.
/// Acceptance (issue 3, polynomial compensation): position <= 0.02 mm, displacement
/// <= 0.01 mm.
/// @throws Error if the options are invalid, the calibration fails or the grid is not
/// found in a frame.
nlohmann::json EvaluateMarkers(const MarkerEvaluationOptions& options);

}  // namespace tac3d
