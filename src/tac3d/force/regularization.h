#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace tac3d {

/// Displacement noise per axis, estimated from frames of a sensor at rest.
struct DisplacementNoise {
  /// Variance of one marker's displacement along x, y, z (mm^2).
  Eigen::Vector3d variance_mm2 = Eigen::Vector3d::Zero();
  int num_frames = 0;
  /// Degrees of freedom behind each axis' variance: sum over markers of (valid frames - 1).
  Eigen::Vector3i degrees_of_freedom = Eigen::Vector3i::Zero();

  /// sqrt(variance_mm2), the 1-sigma noise per axis (mm).
  Eigen::Vector3d sigma_mm() const { return variance_mm2.cwiseSqrt(); }
};

/// Pools, per axis, the variance of every marker's displacement about its own mean over a
/// stack of static frames (so a constant offset, e.g. a stale reference frame, is not noise).
/// NaN entries are skipped; a marker needs two finite frames to contribute.
/// @param static_frames displacements D (3N, paper ordering, mm) of an unloaded sensor.
/// @throws tac3d::Error if there are fewer than 2 frames, their sizes differ or are not a
///   multiple of 3, or an axis has no marker with two finite values.
DisplacementNoise EstimateDisplacementNoise(const std::vector<Eigen::VectorXd>& static_frames);

/// The singular value decomposition H = U diag(s) V^T of a square compliance matrix, which
/// makes every Tikhonov quantity a sum over singular values (Hansen, Rank-Deficient and
/// Discrete Ill-Posed Problems, ch. 4): F_w = V diag(s / (s^2 + w)) U^T D, residual
/// ||H F_w - D||^2 = sum (w / (s^2 + w))^2 (u_i^T D)^2.
class ComplianceSpectrum {
 public:
  /// @param h the 3N x 3N compliance (mm/N).
  /// @throws tac3d::Error if h is empty, not square or has non-finite entries.
  explicit ComplianceSpectrum(const Eigen::MatrixXd& h);

  /// Singular values, decreasing (mm/N).
  const Eigen::VectorXd& singular_values() const { return singular_values_; }
  const Eigen::MatrixXd& u() const { return u_; }
  const Eigen::MatrixXd& v() const { return v_; }
  int size() const { return static_cast<int>(singular_values_.size()); }

  /// The Tikhonov solution F_w = (H^T H + w I)^-1 H^T D (N) for weight w ((mm/N)^2).
  Eigen::VectorXd Solve(const Eigen::VectorXd& d_mm, double weight) const;

 private:
  Eigen::MatrixXd u_;
  Eigen::VectorXd singular_values_;
  Eigen::MatrixXd v_;
};

/// How the Tikhonov weight w of eq. (3) is chosen.
enum class WeightRule {
  /// WeightSelectionOptions::weight as given.
  kGiven,
  /// Morozov's discrepancy principle: the largest w whose residual is no larger than the
  /// noise, ||H F_w - D||^2 = tau E||noise||^2 = tau N (sx^2 + sy^2 + sz^2).
  kDiscrepancy,
  /// Generalised cross-validation (Golub, Heath, Wahba 1979): w minimising
  /// ||H F_w - D||^2 / trace(I - H K_w)^2; needs no noise estimate.
  kGeneralizedCrossValidation,
};

std::string ToString(WeightRule rule);
/// @throws tac3d::Error naming the accepted names ("given", "discrepancy", "gcv").
WeightRule WeightRuleFromString(const std::string& name);

struct WeightSelectionOptions {
  WeightRule rule = WeightRule::kDiscrepancy;
  /// w for kGiven ((mm/N)^2).
  double weight = 0.0;
  /// tau of the discrepancy principle (>= 1; Morozov's safety factor).
  double discrepancy_factor = 1.0;
  /// The search interval of w, relative to the largest s^2.
  double min_relative_weight = 1e-14;
  double max_relative_weight = 1e2;

  /// @throws tac3d::Error naming the field: weight > 0 for kGiven (>= 0 otherwise);
  ///   discrepancy_factor >= 1; 0 < min_relative_weight < max_relative_weight.
  void Validate() const;
};

/// Why the weight is what it is.
struct WeightSelectionSummary {
  WeightRule rule = WeightRule::kGiven;
  /// kDiscrepancy: the residual met the target inside the search interval; kGcv: the
  /// minimum is inside the interval (not at an end).
  bool converged = true;
  /// Frames the choice was made on.
  int num_frames = 0;
  /// Mean squared residual per frame ||H F_w - D||^2 at the chosen w (mm^2).
  double residual_norm2_mm2 = 0.0;
  /// kDiscrepancy: the target tau N trace(S) (mm^2); 0 otherwise.
  double target_residual_norm2_mm2 = 0.0;
  /// Effective number of parameters trace(H K_w), out of 3N.
  double effective_parameters = 0.0;
  /// kGcv: the noise variance GCV implies, residual / trace(I - H K_w) (mm^2); 0 otherwise.
  double implied_noise_variance_mm2 = 0.0;
  /// Function evaluations of the search.
  int evaluations = 0;
  /// One sentence: the rule, and what happened.
  std::string message;
};

struct WeightSelection {
  /// w ((mm/N)^2).
  double weight = 0.0;
  WeightSelectionSummary summary;
};

nlohmann::json ToJson(const WeightSelection& selection);

/// Chooses w for eq. (3) once, on representative loaded frames (e.g. the presses of a force
/// calibration): the residual is summed over them, so one K serves them all.
/// @param frames displacements D (3N, mm) under typical loads; NaN not allowed (use the
///   frames' valid markers only by choosing frames without lost markers).
/// @param noise the displacement noise (EstimateDisplacementNoise); used by kDiscrepancy.
/// @throws tac3d::Error if the options are invalid, a frame has the wrong size or a non-finite
///   entry, kDiscrepancy or kGcv has no frame, or kDiscrepancy has zero noise.
WeightSelection SelectRegularizationWeight(const ComplianceSpectrum& spectrum,
                                           const std::vector<Eigen::VectorXd>& frames,
                                           const DisplacementNoise& noise,
                                           const WeightSelectionOptions& options);

}  // namespace tac3d
