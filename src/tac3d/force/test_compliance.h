#pragma once

// Test-only: the synthetic compliance the pipeline's tests run on (not part of the library).

#include <Eigen/Core>

#include "tac3d/force/synthetic_compliance.h"

namespace tac3d::testing {

/// CalcSyntheticCompliance with its defaults (the built-in sensor's grid), made once per test
/// program.
inline const Eigen::MatrixXd& DefaultSyntheticCompliance() {
  static const Eigen::MatrixXd h = CalcSyntheticCompliance({}).h;
  return h;
}

}  // namespace tac3d::testing
