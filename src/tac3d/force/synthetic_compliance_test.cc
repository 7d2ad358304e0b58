#include "tac3d/force/synthetic_compliance.h"

#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

TEST(SyntheticCompliance, SymmetricAndPositiveDefinite) {
  const SyntheticCompliance model = CalcSyntheticCompliance({.rows = 8, .cols = 6});
  ASSERT_EQ(model.h.rows(), 3 * 48);
  ASSERT_EQ(model.marker_positions.size(), 48u);
  // Maxwell-Betti reciprocity makes H symmetric; elastic energy makes it positive definite.
  EXPECT_LE((model.h - model.h.transpose()).cwiseAbs().maxCoeff(), 1e-15 * model.h.norm());
  const Eigen::VectorXd eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(model.h)
                                          .eigenvalues();
  EXPECT_GT(eigenvalues.minCoeff(), 0.0);
}

TEST(SyntheticCompliance, OwnComplianceIsThatOfAUniformSquarePatch) {
  const SyntheticComplianceOptions options{
      .rows = 3, .cols = 3, .pitch_mm = 1.5, .youngs_modulus_mpa = 2.0, .poisson_ratio = 0.3};
  const SyntheticCompliance model = CalcSyntheticCompliance(options);
  // Love (1929): centre deflection of a square of side a under a uniform load P on a
  // half-space, 4 ln(1 + sqrt 2) (1 - nu^2) P / (pi E a).
  const double expected = 4.0 * std::log(1.0 + std::numbers::sqrt2) * (1.0 - 0.09) /
                          (std::numbers::pi * 2.0 * 1.5);
  const int n = 9;
  EXPECT_NEAR(model.h(2 * n + 4, 2 * n + 4), expected, 1e-12);
}

TEST(SyntheticCompliance, FarFieldIsBoussinesqAndCerruti) {
  const SyntheticComplianceOptions options{.rows = 1, .cols = 30, .pitch_mm = 1.0};
  const SyntheticCompliance model = CalcSyntheticCompliance(options);
  const int n = 30;
  const double rho = 29.0;  // markers 0 and 29 along x
  const double nu = options.poisson_ratio, g = 1.0 / (2.0 * (1.0 + nu));
  // Relative error of the regularised distance: (c / rho)^2 / 2 ~ 4e-5.
  const double tolerance = 1e-4;
  // Normal load: u_z = (1 - nu) / (2 pi G rho), u_x towards the load (1 - 2 nu) / (4 pi G rho).
  EXPECT_NEAR(model.h(2 * n + 29, 2 * n + 0) / ((1 - nu) / (2 * std::numbers::pi * g * rho)), 1.0,
              tolerance);
  EXPECT_NEAR(model.h(29, 2 * n + 0) / ((1 - 2 * nu) / (4 * std::numbers::pi * g * rho)), 1.0,
              tolerance);
  // Tangential load along x at a point along x: u_x = 1 / (2 pi G rho), u_y = 0.
  EXPECT_NEAR(model.h(29, 0) / (1.0 / (2 * std::numbers::pi * g * rho)), 1.0, tolerance);
  EXPECT_EQ(model.h(n + 29, 0), 0.0);
}

TEST(SyntheticCompliance, InvalidOptionsThrow) {
  EXPECT_THROW(CalcSyntheticCompliance({.rows = 0}), Error);
  EXPECT_THROW(CalcSyntheticCompliance({.cols = 201}), Error);
  EXPECT_THROW(CalcSyntheticCompliance({.pitch_mm = 0.0}), Error);
  EXPECT_THROW(CalcSyntheticCompliance({.youngs_modulus_mpa = -1.0}), Error);
  EXPECT_THROW(CalcSyntheticCompliance({.poisson_ratio = 0.5}), Error);
}

}  // namespace
}  // namespace tac3d
