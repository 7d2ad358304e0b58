#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tac3d/eval/calibration_evaluation.h"
#include "tac3d/twin/marker_motion.h"
#include "tac3d/util/eval_check.h"

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
  /// Render the marker frames with the nuisances of a real camera's images
  /// (RenderOptions::WithRealImageNuisances: coloured uneven LEDs, blur, JPEG compression).
  bool real_image_nuisances = false;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// One value a refraction model (RefractionModel, stereo/marker_field.h).
template <typename T>
struct PerRefractionModel {
  T none{};        ///< kNone: triangulated as if through air (for comparison)
  T polynomial{};  ///< kPolynomial: the paper's compensation, the one checked
  T exact{};       ///< kExact: reprojection through the flat layers
};

/// Errors of one refraction model: RMS and maximum over the valid markers of the 3D error
/// vector's length (mm); positions against the true ones, displacements against the true
/// motion.
struct MarkerErrors {
  double position_rmse_mm = 0.0;
  double position_max_mm = 0.0;
  double displacement_rmse_mm = 0.0;
  double displacement_max_mm = 0.0;
};

/// One known motion's last frame.
struct MarkerMotionErrors {
  std::string name;
  /// Markers valid with the polynomial model.
  int valid_markers = 0;
  PerRefractionModel<MarkerErrors> by_model;
};

/// What EvaluateMarkers measured.
struct MarkerEvaluation {
  /// In this order (the acceptance, polynomial compensation, over all frames):
  /// position_rmse_mm <= 0.02 mm, displacement_rmse_mm <= 0.01 mm.
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  /// Over all frames (positions: the undeformed and the moved ones; displacements: the moved).
  PerRefractionModel<MarkerErrors> by_model;
  /// Over the undeformed reference frames alone.
  PerRefractionModel<double> undeformed_position_rmse_mm;
  /// Each motion, in the options' order.
  std::vector<MarkerMotionErrors> motions;
  /// The grid's markers, and the fewest valid in a motion's last frame (polynomial model).
  int markers = 0;
  int min_valid_markers = 0;
  int reference_frames = 0;
  /// The marker frames were rendered with MarkerEvaluationOptions::real_image_nuisances.
  bool real_image_nuisances = false;
  /// With MarkerEvaluationOptions::calibrate: the twin's seed and the calibration's summary;
  /// empty when the designed sensor was measured as known.
  std::uint64_t calibration_seed = 0;
  std::optional<VirtualStereoCalibration::Summary> calibration;

  /// The checks, each model's errors and the verdict, as the CLI prints them.
  std::string Report() const;
};

/// {"checks", "all_pass", "position_rmse_mm", "displacement_rmse_mm" (both the polynomial
///  model's), "by_model": {model: {"position_rmse_mm", "displacement_rmse_mm",
///  "position_max_mm", "displacement_max_mm"}}, "undeformed_position_rmse_mm": {model: ...},
///  "motions": [{"name", "valid_markers", "by_model"}], "markers", "min_valid_markers",
///  "reference_frames", "real_image_nuisances", "calibrated", "calibration" ({"seed", "reprojection_rms_px"} or null),
///  "acceptance" ({check name: tolerance}), "pass" (= all_pass)}; models "none",
///  "polynomial", "exact".
nlohmann::json ToJson(const MarkerEvaluation& evaluation);

/// `tac3d eval markers`: the marker layer rendered through glass and silicone by the twin,
/// undeformed and under each known motion; tracked (MarkerTracker), triangulated and
/// compensated for refraction (MarkerTriangulator) with each model; compared with the true
/// 3D positions and displacements (MarkerEvaluation says what is checked).
/// @throws Error if the options are invalid, the calibration fails or the grid is not
/// found in a frame.
MarkerEvaluation EvaluateMarkers(const MarkerEvaluationOptions& options);

}  // namespace tac3d
