#include "tac3d/force/synthetic_compliance.h"

#include <cmath>
#include <numbers>

#include "tac3d/util/error.h"

namespace tac3d {

void SyntheticComplianceOptions::Validate() const {
  for (const auto& [value, field] : {std::pair{rows, "rows"}, std::pair{cols, "cols"}}) {
    if (value < 1 || value > 200) {
      throw Error(
          fmt::format("SyntheticComplianceOptions.{} must be in [1, 200], got {}", field, value));
    }
  }
  if (!(pitch_mm > 0.0)) {
    throw Error(fmt::format("SyntheticComplianceOptions.pitch_mm must be > 0, got {}", pitch_mm));
  }
  if (!(youngs_modulus_mpa > 0.0)) {
    throw Error(fmt::format("SyntheticComplianceOptions.youngs_modulus_mpa must be > 0, got {}",
                            youngs_modulus_mpa));
  }
  if (!(poisson_ratio > -1.0 && poisson_ratio < 0.5)) {
    throw Error(fmt::format("SyntheticComplianceOptions.poisson_ratio must be in (-1, 0.5), got {}",
                            poisson_ratio));
  }
}

SyntheticCompliance CalcSyntheticCompliance(const SyntheticComplianceOptions& options) {
  options.Validate();
  const int n = options.rows * options.cols;
  SyntheticCompliance result;
  for (int row = 0; row < options.rows; ++row) {
    for (int col = 0; col < options.cols; ++col) {
      result.marker_positions.emplace_back((col - 0.5 * (options.cols - 1)) * options.pitch_mm,
                                           (row - 0.5 * (options.rows - 1)) * options.pitch_mm,
                                           0.0);
    }
  }
  const double nu = options.poisson_ratio;
  const double shear_modulus = options.youngs_modulus_mpa / (2.0 * (1.0 + nu));
  const double c = options.pitch_mm / (4.0 * std::log(1.0 + std::numbers::sqrt2));
  const double scale = 1.0 / (2.0 * std::numbers::pi * shear_modulus);
  result.h.resize(3 * n, 3 * n);
  for (int load = 0; load < n; ++load) {
    for (int marker = 0; marker < n; ++marker) {
      const Eigen::Vector2d p =
          (result.marker_positions[marker] - result.marker_positions[load]).head<2>();
      const double rho2 = p.squaredNorm() + c * c;
      const double rho = std::sqrt(rho2);
      // green(i, j): displacement i of the marker per unit force j at the load.
      Eigen::Matrix3d green;
      green.topLeftCorner<2, 2>() =
          scale * ((1.0 - nu) / rho * Eigen::Matrix2d::Identity() + nu * p * p.transpose() /
                                                                         (rho2 * rho));
      green.block<2, 1>(0, 2) = scale * (1.0 - 2.0 * nu) * p / (2.0 * rho2);
      green.block<1, 2>(2, 0) = -scale * (1.0 - 2.0 * nu) * p.transpose() / (2.0 * rho2);
      green(2, 2) = scale * (1.0 - nu) / rho;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) result.h(i * n + marker, j * n + load) = green(i, j);
      }
    }
  }
  return result;
}

}  // namespace tac3d
