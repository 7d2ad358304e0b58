#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/fem/body_model.h"
#include "tac3d/force/marker_surface.h"
#include "tac3d/material_calibration/material_calibration.h"
#include "tac3d/force/regularization.h"
#include "tac3d/util/eval_check.h"

namespace tac3d {

/// What `tac3d eval force` runs: the inverse built on the nominal H, fed displacements of an
/// independent "true" sensor (a finer FEM mesh, elastic constants off nominal, never H itself)
/// under surface tractions of contact shapes, with Gaussian noise added.
struct EvalForceOptions {
  /// The nominal sensor whose H the inverse uses.
  fem::BodyModelOptions body;
  /// Where the nominal H is cached (fem::LoadOrBuildComplianceModel); empty = build it.
  std::string cache_dir;
  /// The true sensor's mesh refinement relative to the nominal one; 2 halves every edge
  /// (the acceptance asks for edges at most half as long). Above 600,000 free DOFs
  /// (the default dome at 2: 1,257,174) the fem module solves it by two-grid conjugate
  /// gradients instead of a Cholesky factor (fem::BodySolverOptions, docs/fem.md).
  double truth_refinement = 2.0;
  /// The true sensor's shear modulus G and bulk modulus K, as multiples of the nominal ones:
  /// by default both 10% off, the one stiffer and the other softer, so no single gain can
  /// absorb the difference. (G and K are the elastic constants that govern a nearly
  /// incompressible solid; "nu x 0.9" would take the nominal 0.48 to 0.432 and K to 0.32x:
  /// docs/force.md reports that case too, as G x 1.137, K x 0.324.)
  double truth_shear_modulus_factor = 1.1;
  double truth_bulk_modulus_factor = 0.9;
  /// 1-sigma Gaussian noise added to every displacement component (mm).
  double noise_mm = 0.005;
  /// Unloaded noisy frames the noise variance is estimated from.
  int static_frames = 50;
  /// Sphere presses for the gain fit and the choice of w, and separate ones for the test.
  int calibration_presses = 30;
  int test_presses = 30;
  /// Full scale of the normal (z) and tangential (x, y) force (N): presses span it, errors are
  /// a percentage of it.
  double full_scale_normal_n = 10.0;
  double full_scale_tangential_n = 5.0;
  WeightSelectionOptions weight;
  /// The inverse's contact-support re-solve (ForceReconstructorOptions); false: the paper's
  /// F = K D alone.
  bool support_refinement = true;
  ContactOptions contact;
  /// Fit E and nu (CalibrateMaterial) as well as the gains on the calibration presses, over H
  /// built at `poisson_nodes` (cached in cache_dir); the figures are then the calibrated
  /// inverse's, with the gains-only ones reported beside them. False: the gains alone.
  bool calibrate_material = false;
  std::vector<double> poisson_nodes = {0.40, 0.45, 0.48, 0.499};
  /// With calibrate_material: give the fit each calibration press' centre as well (the twin
  /// knows it; MaterialCalibrationOptions::location_weight_n_per_mm).
  bool material_contact_centers = false;
  /// Its weight and support_refinement are the evaluation's own (`weight`, `support_refinement`).
  MaterialCalibrationOptions material;
  std::uint64_t seed = 20221122;
  bool show_progress = true;

  /// @throws tac3d::Error naming the field and its bound: truth_refinement in [1, 4];
  ///   factors > 0 with the true material valid; noise_mm >= 0; static_frames >= 2;
  ///   presses >= 3 each; full scales > 0; and the body, weight and contact options.
  void Validate() const;
  /// The true sensor's material: the nominal one with G and K scaled.
  ElasticMaterial TrueMaterial() const;
  /// Sets the G and K factors so that TrueMaterial() is `truth` (the body's material must be
  /// set first).
  void SetTrueMaterial(const ElasticMaterial& truth);
};

/// What material calibration did in an evaluation (calibrate_material).
struct ForceMaterialFigures {
  MaterialCalibration fit;
  ElasticMaterial truth;
  /// The gains-only inverse on the same test presses, for comparison.
  Eigen::Vector3d gains_only_max_pct_fs = Eigen::Vector3d::Zero();
  Eigen::Vector3d gains_only_rms_pct_fs = Eigen::Vector3d::Zero();
  ForceGainFit gains_only;
};

/// The result of EvaluateForce: the checked figures, typed, and the rest as reported data.
struct ForceEvaluation {
  /// resultant_error_pct_fs <= 2% of full scale (max over test presses and axes, gains fitted
  /// on the calibration presses); probe_center_error_mm <= one pitch (max over probe positions;
  /// the centre is the normal-force-weighted centroid of the contact markers); pins_dip_ratio
  /// <= 0.7 (two pins 2.54 mm apart: the lowest normal force between the two peaks over the
  /// smaller peak, max over the pair's midpoint on a marker and a quarter pitch off it; half a
  /// pitch off, each pin midway between two markers, is reported as the sampling limit);
  /// truth_edge_ratio <= 0.5 (the true mesh's edges at most half the nominal ones).
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  Eigen::Vector3d resultant_error_max_pct_fs = Eigen::Vector3d::Zero();
  Eigen::Vector3d resultant_error_rms_pct_fs = Eigen::Vector3d::Zero();
  double probe_center_error_mm = 0.0;
  double pins_dip_ratio = 0.0;
  WeightSelection weight;
  /// The gains of the evaluated inverse (after the material fit, with calibrate_material).
  ForceGainFit gains;
  ElasticMaterial true_material;
  std::optional<ForceMaterialFigures> material;
  /// Reported, not checked: "noise", "uncertainty", "presses", "probes", "pins",
  /// "truth_model", "timing_s".
  nlohmann::json details;

  /// The figures as the CLI prints them: the checks, the resultant errors, the material fit.
  std::string Report() const;
  /// One line for a point of the material grid: the true material, the resultant error (max
  /// % FS per axis), the fitted material and the gains-only error beside it if fitted.
  std::string GridLine() const;
};

/// {"checks", "all_pass", "resultant_error_pct_fs", "resultant_error_max_pct_fs_xyz",
///  "resultant_error_rms_pct_fs_xyz", "probe_center_error_mm", "pins_dip_ratio", "weight",
///  "gains", "true_youngs_modulus_mpa", "true_poisson_ratio", "material_calibration" (with
///  calibrate_material) and the details' keys}.
nlohmann::json ToJson(const ForceEvaluation& evaluation);

/// Runs the evaluation (ForceEvaluation says what is checked).
/// @throws tac3d::Error if the options are invalid.
ForceEvaluation EvaluateForce(const EvalForceOptions& options);

/// True materials to evaluate the inverse against (docs/force.md's material grid): every
/// Young's modulus factor (times the nominal E) with every Poisson's ratio.
struct MaterialGrid {
  std::vector<double> youngs_modulus_factors = {0.8, 1.0, 1.2};
  std::vector<double> poisson_ratios = {0.45, 0.48, 0.499};

  /// @throws tac3d::Error on an empty list or a factor that is not > 0 and finite.
  void Validate() const;
};

/// EvaluateForce at every point of the grid, with one true model a Poisson's ratio: at a fixed
/// nu the FEM stiffness is proportional to E, so the true displacements at E are those at the
/// nominal E scaled by nominal E / E (exact up to the solver's tolerance). Each point's presses,
/// noise and result are those of EvaluateForce with SetTrueMaterial(E, nu) and the same seed,
/// in the grid's order (nu outer, E inner). A true model takes half an hour at refinement 2, so
/// `on_point` (if set) gets each point as it is done: a later failure (a solve that does not
/// converge) loses none of the earlier points.
/// @throws tac3d::Error if the options, the grid or a point's true material is invalid (before
///   any solve), or a true model's solve fails.
std::vector<ForceEvaluation> EvaluateForceOverMaterials(
    const EvalForceOptions& options,
    const MaterialGrid& grid,
    const std::function<void(const ForceEvaluation&)>& on_point = {});

}  // namespace tac3d
