#pragma once

#include <nlohmann/json.hpp>

#include "tac3d/contact/contact_solver.h"
#include "tac3d/material/elastic_material.h"
#include "tac3d/util/eval_check.h"

namespace tac3d::contact {

/// The contact solver against analytic oracles on an elastic half-space (a thick block): a
/// rigid sphere pressed (Hertz), then sheared (Cattaneo-Mindlin, Mindlin-Deresiewicz), and
/// slid across a surface of two materials.
struct EvalContactOptions {
  /// The block's material (default: the fingertip's silicone).
  ElasticMaterial material;
  double sphere_radius_mm = 10.0;
  double normal_force_n = 1.0;
  /// mu for the Mindlin and history cases.
  double friction_coefficient = 0.5;
  /// The two materials of the sliding case: x < 0 and x >= 0 of the object.
  double friction_coefficient_left = 1.0;
  double friction_coefficient_right = 0.4;
  /// Grid resolution: cells per Hertz contact radius a (the grid spacing is a / this).
  double cells_per_radius = 16.0;
  /// Acceptance (%): Hertz radius, peak, profile RMS, Mindlin stick radius and shift.
  double tolerance_pct = 5.0;
  /// Acceptance (%): |Q| = mu P at full sliding, |q| / p = mu in the slip region.
  double friction_tolerance_pct = 1.0;
  /// Acceptance (%): the residual shift after a load-unload cycle vs Mindlin-Deresiewicz.
  double history_tolerance_pct = 10.0;
  /// Limits and tolerances; the coupling is set by each case (Hertz and the sliding case
  /// kFull, Mindlin and the history kNeglect, the assumption of their analytic solutions).
  ContactSolverOptions solver;

  /// @throws tac3d::Error naming the field: radius, force, mu's > 0, cells_per_radius in
  ///   [4, 64], tolerances > 0, the material and solver options.
  void Validate() const;
};

/// What EvaluateContact measured.
struct EvalContactResult {
  /// In this order: hertz_radius_error_pct, hertz_peak_error_pct, hertz_profile_rms_pct,
  /// mindlin_stick_error_pct, mindlin_shift_error_pct, mindlin_full_slide_error_pct,
  /// history_residual_shift_error_pct, slip_mu_error_pct, and all_converged (every solve
  /// converged, none at the grid's edge).
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  /// Each case's exact and measured values and its solves' convergence summaries: "hertz",
  /// "mindlin", "history", "two_material", "grid".
  nlohmann::json details;

  /// The checks as the CLI prints them, and the verdict.
  std::string Report() const;
};

/// The details' keys with "checks" and "all_pass".
nlohmann::json ToJson(const EvalContactResult& result);

/// Runs the cases (EvalContactResult says what is checked).
/// @throws tac3d::Error if the options are invalid.
EvalContactResult EvaluateContact(const EvalContactOptions& options);

}  // namespace tac3d::contact
