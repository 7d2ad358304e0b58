#include "tac3d/force/regularization.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"

// LAPACK's divide-and-conquer SVD (OpenBLAS provides it). Eigen's BDCSVD computes the same
// decomposition, but instantiating it cost a third of a minute of every build.
extern "C" void dgesdd_(const char* jobz, const int* m, const int* n, double* a, const int* lda,
                        double* s, double* u, const int* ldu, double* vt, const int* ldvt,
                        double* work, const int* lwork, int* iwork, int* info);

namespace tac3d {
namespace {

// Bisection and golden-section searches stop when the bracket of log(w) is this narrow.
constexpr double kLogWeightTolerance = 1e-6;
// Points of the coarse log-spaced GCV scan, which brackets the global minimum.
constexpr int kGcvScanPoints = 200;

// The Tikhonov quantities of a fixed set of frames as functions of w.
class TikhonovCurve {
 public:
  TikhonovCurve(const ComplianceSpectrum& spectrum, const std::vector<Eigen::VectorXd>& frames)
      : s2_(spectrum.singular_values().array().square()),
        beta2_(Eigen::ArrayXd::Zero(spectrum.size())) {
    for (const Eigen::VectorXd& d : frames) beta2_ += (spectrum.u().transpose() * d).array().square();
    if (!frames.empty()) beta2_ /= static_cast<double>(frames.size());
  }

  // Mean squared residual per frame (mm^2).
  double Residual(double w) const { return ((w / (s2_ + w)).square() * beta2_).sum(); }
  // trace(H K_w).
  double EffectiveParameters(double w) const { return (s2_ / (s2_ + w)).sum(); }
  double Gcv(double w) const {
    const double trace = static_cast<double>(s2_.size()) - EffectiveParameters(w);
    return Residual(w) / (trace * trace);
  }

 private:
  Eigen::ArrayXd s2_;
  Eigen::ArrayXd beta2_;  // mean over frames of (u_i^T D)^2
};

void CheckFrames(const std::vector<Eigen::VectorXd>& frames, int size) {
  for (size_t k = 0; k < frames.size(); ++k) {
    if (frames[k].size() != size) {
      throw Error(fmt::format("SelectRegularizationWeight: frame {} has {} entries, H has {} rows",
                              k, frames[k].size(), size));
    }
    if (!frames[k].allFinite()) {
      throw Error(fmt::format("SelectRegularizationWeight: frame {} has a non-finite entry", k));
    }
  }
}

}  // namespace

DisplacementNoise EstimateDisplacementNoise(const std::vector<Eigen::VectorXd>& static_frames) {
  if (static_frames.size() < 2) {
    throw Error(fmt::format("EstimateDisplacementNoise: needs at least 2 static frames, got {}",
                            static_frames.size()));
  }
  const Eigen::Index n = static_frames.front().size();
  if (n == 0 || n % 3 != 0) {
    throw Error(fmt::format(
        "EstimateDisplacementNoise: a frame has {} entries, not a positive multiple of 3", n));
  }
  for (size_t k = 1; k < static_frames.size(); ++k) {
    if (static_frames[k].size() != n) {
      throw Error(fmt::format("EstimateDisplacementNoise: frame {} has {} entries, frame 0 has {}",
                              k, static_frames[k].size(), n));
    }
  }
  const Eigen::Index num_markers = n / 3;
  Eigen::Vector3d sum_squares = Eigen::Vector3d::Zero();
  DisplacementNoise noise;
  noise.num_frames = static_cast<int>(static_frames.size());
  for (Eigen::Index j = 0; j < n; ++j) {
    int count = 0;
    double mean = 0.0, m2 = 0.0;  // Welford's running mean and sum of squared deviations
    for (const Eigen::VectorXd& frame : static_frames) {
      const double x = frame(j);
      if (!std::isfinite(x)) continue;
      ++count;
      const double delta = x - mean;
      mean += delta / count;
      m2 += delta * (x - mean);
    }
    if (count < 2) continue;
    sum_squares(j / num_markers) += m2;
    noise.degrees_of_freedom(j / num_markers) += count - 1;
  }
  for (int axis = 0; axis < 3; ++axis) {
    if (noise.degrees_of_freedom(axis) == 0) {
      throw Error(fmt::format(
          "EstimateDisplacementNoise: axis {} has no marker with two finite values", "xyz"[axis]));
    }
    noise.variance_mm2(axis) = sum_squares(axis) / noise.degrees_of_freedom(axis);
  }
  return noise;
}

ComplianceSpectrum::ComplianceSpectrum(const Eigen::MatrixXd& h) {
  if (h.size() == 0 || h.rows() != h.cols()) {
    throw Error(fmt::format("ComplianceSpectrum: H must be square and non-empty, got {} x {}",
                            h.rows(), h.cols()));
  }
  if (!h.allFinite()) throw Error("ComplianceSpectrum: H has a non-finite entry");
  const int n = static_cast<int>(h.rows());
  Eigen::MatrixXd a = h;  // dgesdd overwrites its input
  Eigen::MatrixXd vt(n, n);
  u_.resize(n, n);
  singular_values_.resize(n);
  std::vector<int> iwork(8 * static_cast<size_t>(n));
  const char jobz = 'S';
  int info = 0;
  int lwork = -1;  // first call: the workspace size
  double optimal_lwork = 0.0;
  dgesdd_(&jobz, &n, &n, a.data(), &n, singular_values_.data(), u_.data(), &n, vt.data(), &n,
          &optimal_lwork, &lwork, iwork.data(), &info);
  if (info == 0) {
    lwork = std::max(1, static_cast<int>(optimal_lwork));
    std::vector<double> work(static_cast<size_t>(lwork));
    dgesdd_(&jobz, &n, &n, a.data(), &n, singular_values_.data(), u_.data(), &n, vt.data(), &n,
            work.data(), &lwork, iwork.data(), &info);
  }
  if (info != 0) {
    throw Error(
        fmt::format("ComplianceSpectrum: the SVD of H failed (LAPACK dgesdd info {})", info));
  }
  v_ = vt.transpose();
}

Eigen::VectorXd ComplianceSpectrum::Solve(const Eigen::VectorXd& d_mm, double weight) const {
  TAC3D_DEMAND(d_mm.size() == size() && weight >= 0.0);
  const Eigen::ArrayXd s = singular_values_.array();
  // s / (s^2 + w) is 0 for a zero singular value and w = 0: the minimum-norm solution.
  const Eigen::ArrayXd filter = (s > 0.0).select(s / (s.square() + weight), 0.0);
  return v_ * (filter * (u_.transpose() * d_mm).array()).matrix();
}

std::string ToString(WeightRule rule) {
  switch (rule) {
    case WeightRule::kGiven:
      return "given";
    case WeightRule::kDiscrepancy:
      return "discrepancy";
    case WeightRule::kGeneralizedCrossValidation:
      return "gcv";
  }
  TAC3D_DEMAND(false);
}

WeightRule WeightRuleFromString(const std::string& name) {
  for (WeightRule rule : {WeightRule::kGiven, WeightRule::kDiscrepancy,
                          WeightRule::kGeneralizedCrossValidation}) {
    if (ToString(rule) == name) return rule;
  }
  throw Error(fmt::format("weight rule must be given, discrepancy or gcv, got '{}'", name));
}

void WeightSelectionOptions::Validate() const {
  if (rule == WeightRule::kGiven ? !(weight > 0.0 && std::isfinite(weight)) : !(weight >= 0.0)) {
    throw Error(fmt::format("WeightSelectionOptions.weight must be {} (mm/N)^2, got {}",
                            rule == WeightRule::kGiven ? "> 0 and finite for rule given" : ">= 0",
                            weight));
  }
  if (!(discrepancy_factor >= 1.0 && std::isfinite(discrepancy_factor))) {
    throw Error(fmt::format("WeightSelectionOptions.discrepancy_factor must be >= 1, got {}",
                            discrepancy_factor));
  }
  if (!(min_relative_weight > 0.0)) {
    throw Error(fmt::format("WeightSelectionOptions.min_relative_weight must be > 0, got {}",
                            min_relative_weight));
  }
  if (!(max_relative_weight > min_relative_weight && std::isfinite(max_relative_weight))) {
    throw Error(fmt::format(
        "WeightSelectionOptions.max_relative_weight must be > min_relative_weight = {}, got {}",
        min_relative_weight, max_relative_weight));
  }
}

nlohmann::json ToJson(const WeightSelection& selection) {
  const WeightSelectionSummary& s = selection.summary;
  return {
      {"weight", selection.weight},
      {"rule", ToString(s.rule)},
      {"converged", s.converged},
      {"num_frames", s.num_frames},
      {"residual_norm2_mm2", s.residual_norm2_mm2},
      {"target_residual_norm2_mm2", s.target_residual_norm2_mm2},
      {"effective_parameters", s.effective_parameters},
      {"implied_noise_variance_mm2", s.implied_noise_variance_mm2},
      {"evaluations", s.evaluations},
      {"message", s.message},
  };
}

WeightSelection SelectRegularizationWeight(const ComplianceSpectrum& spectrum,
                                           const std::vector<Eigen::VectorXd>& frames,
                                           const DisplacementNoise& noise,
                                           const WeightSelectionOptions& options) {
  options.Validate();
  CheckFrames(frames, spectrum.size());
  if (options.rule != WeightRule::kGiven && frames.empty()) {
    throw Error(fmt::format("SelectRegularizationWeight: rule {} needs at least one loaded frame",
                            ToString(options.rule)));
  }
  const TikhonovCurve curve(spectrum, frames);
  const double s_max2 = std::pow(spectrum.singular_values()(0), 2);
  const double log_lo = std::log(options.min_relative_weight * s_max2);
  const double log_hi = std::log(options.max_relative_weight * s_max2);

  WeightSelection selection;
  WeightSelectionSummary& summary = selection.summary;
  summary.rule = options.rule;
  summary.num_frames = static_cast<int>(frames.size());
  switch (options.rule) {
    case WeightRule::kGiven:
      selection.weight = options.weight;
      summary.message = fmt::format("w = {:.4g} (mm/N)^2 given", options.weight);
      break;
    case WeightRule::kDiscrepancy: {
      if (!(noise.variance_mm2.sum() > 0.0)) {
        throw Error("SelectRegularizationWeight: the discrepancy principle needs a noise "
                    "variance > 0");
      }
      summary.target_residual_norm2_mm2 =
          options.discrepancy_factor * (spectrum.size() / 3) * noise.variance_mm2.sum();
      const double target = summary.target_residual_norm2_mm2;
      summary.evaluations = 2;
      if (curve.Residual(std::exp(log_hi)) < target) {
        selection.weight = std::exp(log_hi);
        summary.converged = false;
        summary.message = "discrepancy principle: the frames are within the noise even at the "
                          "largest w (no load?); w set to the largest";
      } else if (curve.Residual(std::exp(log_lo)) > target) {
        selection.weight = std::exp(log_lo);
        summary.converged = false;
        summary.message = "discrepancy principle: the residual exceeds the noise even at the "
                          "smallest w (noise underestimated, or model error); w set to the "
                          "smallest";
      } else {
        // The residual increases with w: bisect log(w).
        double lo = log_lo, hi = log_hi;
        while (hi - lo > kLogWeightTolerance) {
          const double mid = 0.5 * (lo + hi);
          (curve.Residual(std::exp(mid)) < target ? lo : hi) = mid;
          ++summary.evaluations;
        }
        selection.weight = std::exp(0.5 * (lo + hi));
        summary.message = fmt::format(
            "discrepancy principle: residual = {} x {} markers x noise variance {:.3g} mm^2",
            options.discrepancy_factor, spectrum.size() / 3, noise.variance_mm2.sum());
      }
      break;
    }
    case WeightRule::kGeneralizedCrossValidation: {
      int best = 0;
      double best_value = INFINITY;
      const double step = (log_hi - log_lo) / (kGcvScanPoints - 1);
      for (int k = 0; k < kGcvScanPoints; ++k) {
        const double value = curve.Gcv(std::exp(log_lo + k * step));
        if (value < best_value) best_value = value, best = k;
      }
      summary.evaluations = kGcvScanPoints;
      // Golden-section search in the scan's bracket around the best point.
      double a = log_lo + std::max(best - 1, 0) * step;
      double b = log_lo + std::min(best + 1, kGcvScanPoints - 1) * step;
      const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
      double c = b - ratio * (b - a), d = a + ratio * (b - a);
      double fc = curve.Gcv(std::exp(c)), fd = curve.Gcv(std::exp(d));
      summary.evaluations += 2;
      while (b - a > kLogWeightTolerance) {
        if (fc < fd) {
          b = d, d = c, fd = fc;
          c = b - ratio * (b - a), fc = curve.Gcv(std::exp(c));
        } else {
          a = c, c = d, fc = fd;
          d = a + ratio * (b - a), fd = curve.Gcv(std::exp(d));
        }
        ++summary.evaluations;
      }
      selection.weight = std::exp(0.5 * (a + b));
      summary.converged = best > 0 && best < kGcvScanPoints - 1;
      summary.message =
          summary.converged
              ? "generalised cross-validation: the minimum of the GCV function"
              : "generalised cross-validation: the minimum is at an end of the search interval";
      summary.implied_noise_variance_mm2 =
          curve.Residual(selection.weight) /
          (spectrum.size() - curve.EffectiveParameters(selection.weight));
      break;
    }
  }
  summary.residual_norm2_mm2 = frames.empty() ? 0.0 : curve.Residual(selection.weight);
  summary.effective_parameters = curve.EffectiveParameters(selection.weight);
  return selection;
}

}  // namespace tac3d
