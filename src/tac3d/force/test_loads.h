#pragma once

// Test-only helpers shared by the force module's tests (not part of the library).

#include <cmath>
#include <vector>

#include <Eigen/Core>

namespace tac3d::testing {

/// A smooth contact load in the paper's ordering (N): a Hertz-like bump
/// sqrt(1 - r^2 / a^2) of total force `total_n` centred at `center_mm`, on every marker.
inline Eigen::VectorXd MakeBumpLoad(const std::vector<Eigen::Vector3d>& markers,
                                    const Eigen::Vector2d& center_mm,
                                    double radius_mm,
                                    const Eigen::Vector3d& total_n) {
  const int n = static_cast<int>(markers.size());
  Eigen::VectorXd weights = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    const double r2 = (markers[i].head<2>() - center_mm).squaredNorm() / (radius_mm * radius_mm);
    if (r2 < 1.0) weights(i) = std::sqrt(1.0 - r2);
  }
  weights /= weights.sum();
  Eigen::VectorXd f(3 * n);
  for (int axis = 0; axis < 3; ++axis) f.segment(axis * n, n) = total_n(axis) * weights;
  return f;
}

}  // namespace tac3d::testing
