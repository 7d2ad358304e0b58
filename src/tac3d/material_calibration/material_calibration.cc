#include "tac3d/material_calibration/material_calibration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>

#include "tac3d/fem/compliance_family.h"
#include "tac3d/force/force_reconstructor.h"
#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

// 1 / golden ratio: the golden-section search keeps this fraction of its bracket each step.
constexpr double kGoldenFraction = 0.6180339887498949;
// Half the nu step of the sensitivity's central difference: wide enough that a marker crossing
// the support threshold between the two ends (a small jump in the resultants) is not mistaken
// for a derivative, narrow enough that the resultants are still linear in nu across it.
constexpr double kSensitivityStep = 0.005;

// The resultants of one candidate nu: stacked (fx, fy, fz) per press (3P, N), unit gains, E
// the family's; the E-scale that fits them to the references best; the located presses'
// centre errors (x, y stacked, mm); and the residual nu minimises, forces and weighted centres.
struct Trial {
  MaterialCandidate candidate;
  Eigen::VectorXd resultants_n;
  Eigen::VectorXd center_errors_mm;
  double scale = 1.0;
  double residual_norm2_n2 = 0.0;
};

// The centroid (x, y) of the compressive normal marker forces (mm): where the inverse puts the
// contact. The rest positions; nullopt when no marker is pushed in.
std::optional<Eigen::Vector2d> ContactCentroid(const ForceFrame& frame,
                                               const std::vector<Eigen::Vector3d>& markers) {
  const int n = frame.num_markers();
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    const double pressed = std::max(0.0, -frame.forces_n(2 * n + i));
    sum += pressed * markers[i].head<2>();
    total += pressed;
  }
  if (!(total > 0.0)) return std::nullopt;
  return sum / total;
}

// Everything a trial needs, so the search can call it with nu alone.
class PoissonObjective {
 public:
  PoissonObjective(const fem::ComplianceFamily& family,
                   const std::vector<CalibrationPress>& presses,
                   const DisplacementNoise& noise,
                   const MaterialCalibrationOptions& options)
      : family_(family), presses_(presses), noise_(noise), options_(options) {
    for (const CalibrationPress& press : presses) {
      frames_.push_back(press.displacement_mm);
      if (press.contact_center_mm && options.location_weight_n_per_mm > 0.0) ++num_located_;
    }
    references_n_.resize(3 * static_cast<Eigen::Index>(presses.size()));
    for (size_t k = 0; k < presses.size(); ++k)
      references_n_.segment<3>(3 * k) = presses[k].reference_n;
  }

  // The inverse on H(material) with w chosen on the presses.
  ForceReconstructor MakeReconstructor(const ElasticMaterial& material, double* weight) const {
    const Eigen::MatrixXd h = family_.CalcH(material);
    *weight =
        SelectRegularizationWeight(ComplianceSpectrum(h), frames_, noise_, options_.weight).weight;
    return ForceReconstructor(
        h,
        family_.marker_positions(),
        {.weight = *weight, .support_refinement = options_.support_refinement});
  }

  Trial Evaluate(double poisson_ratio) {
    ElasticMaterial material = family_.options().material;
    material.poisson_ratio = poisson_ratio;
    double weight = 0.0;
    ForceReconstructor reconstructor = MakeReconstructor(material, &weight);
    Trial trial;
    trial.resultants_n.resize(references_n_.size());
    trial.center_errors_mm.resize(2 * num_located_);
    int located = 0;
    for (size_t k = 0; k < presses_.size(); ++k) {
      const ForceFrame frame = reconstructor.Reconstruct(frames_[k]);
      trial.resultants_n.segment<3>(3 * k) = frame.resultant_force_n;
      if (!presses_[k].contact_center_mm || options_.location_weight_n_per_mm <= 0.0) continue;
      // No pushed-in marker counts as missing the centre by the sensing area's half width.
      const std::optional<Eigen::Vector2d> centroid =
          ContactCentroid(frame, family_.marker_positions());
      trial.center_errors_mm.segment<2>(2 * located++) =
          centroid ? Eigen::Vector2d(*centroid - *presses_[k].contact_center_mm)
                   : Eigen::Vector2d::Constant(family_.options().base_radius_mm());
    }
    // H / E makes the forces E times larger: E is the least-squares scale of m onto r; the
    // centroid does not change with the scale.
    trial.scale = trial.resultants_n.dot(references_n_) / trial.resultants_n.squaredNorm();
    const double force_norm2 = (references_n_ - trial.scale * trial.resultants_n).squaredNorm();
    const double location_weight = options_.location_weight_n_per_mm;
    trial.residual_norm2_n2 =
        force_norm2 + location_weight * location_weight * trial.center_errors_mm.squaredNorm();
    trial.candidate = {
        poisson_ratio,
        trial.scale * material.youngs_modulus_mpa,
        std::sqrt(force_norm2 / references_n_.size()),
        num_located_ > 0 ? std::sqrt(trial.center_errors_mm.squaredNorm() / num_located_) : 0.0};
    trials_.push_back(trial);
    return trial;
  }

  const Eigen::VectorXd& references_n() const { return references_n_; }
  int num_located() const { return num_located_; }
  const std::vector<Trial>& trials() const { return trials_; }

 private:
  const fem::ComplianceFamily& family_;
  const std::vector<CalibrationPress>& presses_;
  const DisplacementNoise& noise_;
  const MaterialCalibrationOptions& options_;
  std::vector<Eigen::VectorXd> frames_;
  int num_located_ = 0;
  Eigen::VectorXd references_n_;
  std::vector<Trial> trials_;
};

// The nu of least residual: the family's nodes first, then golden section between the best
// node's neighbours (the residual is unimodal there in every case seen; the nodes keep a
// second minimum elsewhere from being missed silently, since the best trial overall wins).
Trial SearchPoissonRatio(const fem::ComplianceFamily& family,
                         double tolerance,
                         PoissonObjective* objective) {
  const std::vector<double>& nodes = family.poisson_nodes();
  size_t best_node = 0;
  double best_residual = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < nodes.size(); ++i) {
    const double residual = objective->Evaluate(nodes[i]).residual_norm2_n2;
    if (residual < best_residual) best_node = i, best_residual = residual;
  }
  double a = nodes[best_node > 0 ? best_node - 1 : 0];
  double b = nodes[std::min(best_node + 1, nodes.size() - 1)];
  double x1 = b - kGoldenFraction * (b - a), x2 = a + kGoldenFraction * (b - a);
  double f1 = objective->Evaluate(x1).residual_norm2_n2;
  double f2 = objective->Evaluate(x2).residual_norm2_n2;
  while (b - a > tolerance) {
    if (f1 < f2) {
      b = x2, x2 = x1, f2 = f1;
      x1 = b - kGoldenFraction * (b - a);
      f1 = objective->Evaluate(x1).residual_norm2_n2;
    } else {
      a = x1, x1 = x2, f1 = f2;
      x2 = a + kGoldenFraction * (b - a);
      f2 = objective->Evaluate(x2).residual_norm2_n2;
    }
  }
  return *std::min_element(
      objective->trials().begin(), objective->trials().end(), [](const Trial& p, const Trial& q) {
        return p.residual_norm2_n2 < q.residual_norm2_n2;
      });
}

// Linearised least squares at the best nu: the error of the fitted nu caused by a data error
// e is J_perp^T e / |J_perp|^2, J_perp the derivative of the fitted resultants by nu with its
// component along the resultants (what E can mimic) removed, stacked with the weighted
// derivative of the centre errors (E does not move them). A model error of relative size eps
// in the worst direction gives eps |r| / |J_perp|; the residual, as independent noise of
// variance sigma^2 per component, 2 sigma / |J_perp| (2-sigma).
void BoundPoissonError(const fem::ComplianceFamily& family,
                       const Trial& best,
                       const MaterialCalibrationOptions& options,
                       PoissonObjective* objective,
                       MaterialCalibration* result) {
  const double nu = best.candidate.poisson_ratio;
  const double below = std::max(family.min_poisson_ratio(), nu - kSensitivityStep);
  const double above = std::min(family.max_poisson_ratio(), nu + kSensitivityStep);
  const Trial trial_below = objective->Evaluate(below);
  const Trial trial_above = objective->Evaluate(above);
  const Eigen::VectorXd& m = best.resultants_n;
  const Eigen::VectorXd derivative =
      best.scale * (trial_above.resultants_n - trial_below.resultants_n) / (above - below);
  const Eigen::Index located = best.center_errors_mm.size();
  Eigen::VectorXd perpendicular(m.size() + located);
  perpendicular << derivative - derivative.dot(m) / m.squaredNorm() * m,
      options.location_weight_n_per_mm *
          (trial_above.center_errors_mm - trial_below.center_errors_mm) / (above - below);
  const double references_norm = objective->references_n().norm();
  const auto dof = static_cast<double>(std::max<Eigen::Index>(1, perpendicular.size() - 2));
  const double sigma_n = std::sqrt(best.residual_norm2_n2 / dof);
  result->poisson_sensitivity = perpendicular.norm() / references_norm;
  result->poisson_error_bound =
      (options.model_relative_error * references_norm + 2.0 * sigma_n) / perpendicular.norm();
}

void CheckPresses(const fem::ComplianceFamily& family,
                  const std::vector<CalibrationPress>& presses) {
  if (static_cast<int>(presses.size()) < kMinForcePairs) {
    throw Error(fmt::format(
        "material calibration needs at least {} presses, got {}", kMinForcePairs, presses.size()));
  }
  const auto size = static_cast<Eigen::Index>(3 * family.marker_positions().size());
  for (size_t k = 0; k < presses.size(); ++k) {
    if (presses[k].displacement_mm.size() != size || !presses[k].displacement_mm.allFinite()) {
      throw Error(fmt::format("press {}: expected {} finite displacements, got {}",
                              k,
                              size,
                              presses[k].displacement_mm.size()));
    }
  }
}

}  // namespace

void MaterialCalibrationOptions::Validate() const {
  weight.Validate();
  gain_fit.Validate();
  if (!(poisson_tolerance > 0.0 && poisson_tolerance <= 0.05)) {
    throw Error(
        fmt::format("MaterialCalibrationOptions.poisson_tolerance must be in (0, 0.05], got {}",
                    poisson_tolerance));
  }
  if (!(model_relative_error >= 0.0 && std::isfinite(model_relative_error))) {
    throw Error(fmt::format("MaterialCalibrationOptions.model_relative_error must be >= 0, got {}",
                            model_relative_error));
  }
  if (!(location_weight_n_per_mm >= 0.0 && std::isfinite(location_weight_n_per_mm))) {
    throw Error(fmt::format(
        "MaterialCalibrationOptions.location_weight_n_per_mm must be >= 0 and finite, got {}",
        location_weight_n_per_mm));
  }
  if (!(max_poisson_error > 0.0)) {
    throw Error(fmt::format("MaterialCalibrationOptions.max_poisson_error must be > 0, got {}",
                            max_poisson_error));
  }
}

nlohmann::json ToJson(const MaterialCalibration& c) {
  nlohmann::json evaluations = nlohmann::json::array();
  for (const MaterialCandidate& e : c.evaluations) {
    evaluations.push_back({{"poisson_ratio", e.poisson_ratio},
                           {"youngs_modulus_mpa", e.youngs_modulus_mpa},
                           {"residual_rms_n", e.residual_rms_n},
                           {"location_residual_rms_mm", e.location_residual_rms_mm}});
  }
  return {{"youngs_modulus_mpa", c.material.youngs_modulus_mpa},
          {"poisson_ratio", c.material.poisson_ratio},
          {"residual_rms_n", c.residual_rms_n},
          {"location_residual_rms_mm", c.location_residual_rms_mm},
          {"num_located_presses", c.num_located_presses},
          {"poisson_sensitivity", c.poisson_sensitivity},
          {"poisson_error_bound", c.poisson_error_bound},
          {"at_range_limit", c.at_range_limit},
          {"weight", c.weight},
          {"gains", ToJson(c.gains)},
          {"evaluations", evaluations},
          {"time_s", c.time_s},
          {"message", c.message}};
}

MaterialCalibration CalibrateMaterial(const fem::ComplianceFamily& family,
                                      const std::vector<CalibrationPress>& presses,
                                      const DisplacementNoise& noise,
                                      const MaterialCalibrationOptions& options) {
  options.Validate();
  CheckPresses(family, presses);
  const auto start = std::chrono::steady_clock::now();
  PoissonObjective objective(family, presses, noise, options);
  const Trial best = SearchPoissonRatio(family, options.poisson_tolerance, &objective);

  MaterialCalibration result;
  result.material = {best.candidate.youngs_modulus_mpa, best.candidate.poisson_ratio};
  result.residual_rms_n = best.candidate.residual_rms_n;
  result.location_residual_rms_mm = best.candidate.location_residual_rms_mm;
  result.num_located_presses = objective.num_located();
  result.at_range_limit = best.candidate.poisson_ratio == family.min_poisson_ratio() ||
                          best.candidate.poisson_ratio == family.max_poisson_ratio();
  BoundPoissonError(family, best, options, &objective, &result);
  for (const Trial& trial : objective.trials()) result.evaluations.push_back(trial.candidate);
  if (!(result.poisson_error_bound <= options.max_poisson_error)) {
    throw Error(fmt::format(
        "the presses cannot determine Poisson's ratio: with E free, nu changes their resultants "
        "by only {:.3g} of the reference forces per unit nu, so a model error of {:.2g}% and the "
        "residual ({:.3g} N RMS) leave nu uncertain by {:.3g} (more than {:.3g}). Normal presses "
        "see nu almost only as a scale, which E absorbs: add presses with tangential force in "
        "both x and y (docs/force.md){}",
        result.poisson_sensitivity,
        100.0 * options.model_relative_error,
        result.residual_rms_n,
        result.poisson_error_bound,
        options.max_poisson_error,
        result.num_located_presses > 0
            ? fmt::format(". The {} contact centres are {:.3g} mm RMS off the inverse's, which "
                          "adds to the residual: a probe placed elsewhere than the file says "
                          "does that",
                          result.num_located_presses,
                          result.location_residual_rms_mm)
            : ""));
  }

  // The gains on top of the fitted material, on the inverse the pipeline will run.
  ForceReconstructor reconstructor = objective.MakeReconstructor(result.material, &result.weight);
  std::vector<ForcePair> pairs;
  for (const CalibrationPress& press : presses) {
    pairs.push_back(
        {reconstructor.Reconstruct(press.displacement_mm).resultant_force_n, press.reference_n});
  }
  result.gains = FitForceGains(pairs, options.gain_fit);
  result.time_s = SecondsSince(start);
  result.message = fmt::format(
      "E {:.4g} MPa, nu {:.4f} (+-{:.4f}) from {} presses{} in {} evaluations{}",
      result.material.youngs_modulus_mpa,
      result.material.poisson_ratio,
      result.poisson_error_bound,
      presses.size(),
      result.num_located_presses > 0
          ? fmt::format(" ({} with contact centres, {:.3f} mm RMS off)", result.num_located_presses,
                        result.location_residual_rms_mm)
          : "",
      result.evaluations.size(),
      result.at_range_limit ? "; nu is at the end of the family's range, the truth may lie beyond"
                            : "");
  return result;
}

}  // namespace tac3d
