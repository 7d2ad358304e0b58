#pragma once

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/force/force_gains.h"
#include "tac3d/force/regularization.h"
#include "tac3d/material/elastic_material.h"

namespace tac3d {
namespace fem {
class ComplianceFamily;
}

struct MaterialCalibrationOptions {
  /// How w is chosen for each candidate H (on the presses themselves).
  WeightSelectionOptions weight;
  /// The inverse's contact-support re-solve (ForceReconstructorOptions), as in the pipeline.
  bool support_refinement = true;
  /// The search over nu stops when its bracket is this narrow.
  double poisson_tolerance = 1e-3;
  /// The relative error of the FEM's resultants that no material explains and that is not a
  /// scale (E absorbs a scale): 0.003 on the default sensor. docs/force.md measured the RMS Fz
  /// error after the gain fit at 0.41% FS with the true sensor refined 1.5x and G, K off, and
  /// 0.37% FS with the nominal H as its own truth (noise alone); the model's part is
  /// sqrt(0.41^2 - 0.37^2) = 0.18% FS, 0.3% of a typical press (6 N). A model error of this
  /// size in the worst direction moves the fitted nu by model_relative_error / sensitivity.
  double model_relative_error = 0.003;
  /// The largest bound on nu's error accepted (default 0.005: on the default sensor nu off by
  /// 0.048 gave a resultant error of 9.2% FS, so 0.005 costs about 1% FS, half of the 2% budget).
  double max_poisson_error = 0.005;
  /// How much a press' contact centre counts, where the press has one: a centre error of 1 mm
  /// weighs as a resultant error of this many newtons in the residual nu minimises. The centre
  /// the inverse finds is the centroid of its compressive normal marker forces; it does not
  /// depend on E. 0 ignores the centres.
  double location_weight_n_per_mm = 0.1;
  /// The gains' fit on the fitted material (FitForceGains): its R^2 floor, refused below.
  ForceGainFitOptions gain_fit;

  /// @throws tac3d::Error naming the field: the weight and gain-fit options; poisson_tolerance in
  ///   (0, 0.05]; model_relative_error >= 0; max_poisson_error > 0; location_weight_n_per_mm
  ///   >= 0 and finite.
  void Validate() const;
};

/// One nu the search tried.
struct MaterialCandidate {
  double poisson_ratio = 0.0;
  /// E that best scales the resultants at this nu (MPa).
  double youngs_modulus_mpa = 0.0;
  /// RMS over presses and axes of reference - resultant (N), unit gains.
  double residual_rms_n = 0.0;
  /// RMS over the presses with a contact centre of its distance to the centre the inverse
  /// finds (mm); 0 without centres.
  double location_residual_rms_mm = 0.0;
};

/// The fitted material and the gains left on top of it.
struct MaterialCalibration {
  ElasticMaterial material;
  /// RMS of reference - resultant over presses and axes with the fitted material and unit
  /// gains (N): what the material alone explains.
  double residual_rms_n = 0.0;
  /// The contact centres' RMS error with the fitted material (mm), over the presses that
  /// have one (num_located_presses); 0 when none has.
  double location_residual_rms_mm = 0.0;
  int num_located_presses = 0;
  /// |d resultants / d nu| with the part a change of E can mimic removed, over |references|
  /// (per unit nu): how strongly the presses see nu.
  double poisson_sensitivity = 0.0;
  /// model_relative_error / poisson_sensitivity + 2 sigma_nu (sigma_nu from the residual):
  /// how far the fitted nu may be from the truth.
  double poisson_error_bound = 0.0;
  /// True when the best nu is the end of the family's range: the truth may lie beyond it.
  bool at_range_limit = false;
  /// w for the fitted material's H ((mm/N)^2).
  double weight = 0.0;
  /// Per-axis gains fitted on the presses with the fitted material (FitForceGains): ~1 if the
  /// FEM with this material explains the sensor, their spread its remaining model error.
  ForceGainFit gains;
  /// Every nu tried, in order.
  std::vector<MaterialCandidate> evaluations;
  double time_s = 0.0;
  std::string message;
};

nlohmann::json ToJson(const MaterialCalibration& calibration);

/// Fits Young's modulus and Poisson's ratio, then the per-axis gains, to force-calibration
/// presses (docs/force.md, "Material calibration"). For each candidate nu the inverse is built
/// on the family's H (w chosen on the presses) and the resultants m_k(nu) computed; since H
/// scales as 1 / E exactly, E is the least-squares scale of m onto the references in closed
/// form, and nu minimises the remaining residual (the family's nodes, then golden section),
/// to which the presses' contact centres add, where given, their distance to the centres the
/// inverse finds (weighted by options.location_weight_n_per_mm).
/// nu is accepted only if the presses determine it: its effect on the resultants that a change
/// of E cannot mimic must be large enough that the model error and the residual noise move nu
/// by at most options.max_poisson_error. Normal presses fail this: nu changes a normal press'
/// resultant almost only by a scale, which E absorbs; tangential presses see nu through the
/// ratio of the normal to the shear stiffness.
/// @param noise the displacement noise, for the discrepancy principle.
/// @throws tac3d::Error if the options are invalid, there are fewer than kMinForcePairs
///   presses, a displacement has the wrong size, the presses cannot determine nu (the message
///   gives the bound and what to add), or FitForceGains refuses the gains.
MaterialCalibration CalibrateMaterial(const fem::ComplianceFamily& family,
                                      const std::vector<CalibrationPress>& presses,
                                      const DisplacementNoise& noise,
                                      const MaterialCalibrationOptions& options);

}  // namespace tac3d
