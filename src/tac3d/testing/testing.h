#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <gmock/gmock.h>

namespace tac3d::testing {

/// The one seed every randomised test starts from, so failures reproduce.
inline constexpr std::uint64_t kRandomSeed = 20221122;

/// A fresh, empty directory under the test's temporary directory.
std::string MakeTempDir(const std::string& name);

}  // namespace tac3d::testing

/// Matches an Eigen matrix within an absolute tolerance of the expected one.
MATCHER_P2(EigenNear, expected, tolerance, "") {
  if (arg.rows() != expected.rows() || arg.cols() != expected.cols()) {
    *result_listener << "shape " << arg.rows() << "x" << arg.cols();
    return false;
  }
  const double error = (arg - expected).cwiseAbs().maxCoeff();
  *result_listener << "max abs error " << error;
  return error <= tolerance;
}
