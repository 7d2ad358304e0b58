#include "tac3d/fem/evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

TEST(PatchTest, DistortedMeshReproducesLinearField) {
  for (double nu : {0.3, 0.4999}) {
    const PatchTestResult result = RunPatchTest({.poisson_ratio = nu});
    EXPECT_LT(result.max_displacement_error_mm, 1e-10) << "nu " << nu;
    EXPECT_LT(result.max_relative_stress_error, 1e-8) << "nu " << nu;
  }
}

TEST(ConfinedBlock, MatchesConstrainedModulus) {
  // The exact field (u_z linear in z) lies in the element space, so the only error is
  // rounding: far inside the 1% the model needs.
  for (double nu : {0.3, 0.48, 0.499}) {
    const ConfinedBlockResult result = RunConfinedBlock(nu);
    EXPECT_LT(result.relative_error, 1e-9) << "nu " << nu;
    EXPECT_NEAR(result.exact_modulus_mpa, (1 - nu) / ((1 + nu) * (1 - 2 * nu)), 1e-12);
  }
}

TEST(HalfSpace, BoussinesqAndCerrutiAreReciprocal) {
  // Maxwell-Betti: F1 . u(F2 at p2; p1) = F2 . u(F1 at p1; p2), with u depending on p1 - p2.
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const ElasticMaterial material{2.0, 0.3};
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Vector3d f1(uniform(rng), uniform(rng), uniform(rng));
    const Eigen::Vector3d f2(uniform(rng), uniform(rng), uniform(rng));
    const Eigen::Vector2d p1(uniform(rng), uniform(rng));
    const Eigen::Vector2d p2 = p1 + Eigen::Vector2d(2 + uniform(rng), uniform(rng));
    const double w12 = f1.dot(CalcHalfSpaceSurfaceDisplacement(f2, material, p1 - p2));
    const double w21 = f2.dot(CalcHalfSpaceSurfaceDisplacement(f1, material, p2 - p1));
    EXPECT_NEAR(w12, w21, 1e-12 * std::abs(w12) + 1e-15);
  }
}

TEST(HalfSpace, MatchesJohnsonsFormsInE) {
  // Johnson, Contact Mechanics, eq. 3.19 and 3.86 written with E = 2 G (1 + nu), r = 2 mm.
  const double e = 3.0, nu = 0.3, r = 2.0, pi = std::numbers::pi;
  const ElasticMaterial material{e, nu};
  const Eigen::Vector3d normal =
      CalcHalfSpaceSurfaceDisplacement({0, 0, -1}, material, Eigen::Vector2d(r, 0));
  EXPECT_NEAR(normal.z(), -(1 - nu * nu) / (pi * e * r), 1e-15);
  EXPECT_NEAR(normal.x(), -(1 - 2 * nu) * (1 + nu) / (2 * pi * e * r), 1e-15);
  EXPECT_NEAR(normal.y(), 0.0, 1e-15);
  const Eigen::Vector3d across =
      CalcHalfSpaceSurfaceDisplacement({1, 0, 0}, material, Eigen::Vector2d(0, r));
  EXPECT_THAT(across, EigenNear(Eigen::Vector3d((1 - nu * nu) / (pi * e * r), 0, 0), 1e-15));
  const Eigen::Vector3d ahead =
      CalcHalfSpaceSurfaceDisplacement({1, 0, 0}, material, Eigen::Vector2d(r, 0));
  EXPECT_THAT(
      ahead,
      EigenNear(
          Eigen::Vector3d((1 + nu) / (pi * e * r), 0, -(1 - 2 * nu) * (1 + nu) / (2 * pi * e * r)),
          1e-15));
}

TEST(PointLoad, MatchesBoussinesqAndCerruti) {
  for (double nu : {0.3, 0.48}) {
    for (bool tangential : {false, true}) {
      const PointLoadResult result = RunPointLoad({.poisson_ratio = nu, .tangential = tangential});
      EXPECT_LT(result.max_relative_error, 0.10) << "nu " << nu << " tangential " << tangential;
      EXPECT_EQ(result.probes.size(), 18u);
    }
  }
}

TEST(PointLoadOptions, ValidateThrowsOutOfBounds) {
  EXPECT_NO_THROW(PointLoadOptions{}.Validate());
  const auto with = [](auto change) {
    PointLoadOptions options;
    change(options);
    return options;
  };
  EXPECT_THROW(with([](auto& o) { o.poisson_ratio = 0.5; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.patch_half_width_mm = 0; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.finest_element_mm = 0; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.finest_element_mm = 1.0; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.grading_ratio = 0.9; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.grading_ratio = 2.1; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.probe_distances_mm = {0.4}; }).Validate(), Error);
  EXPECT_THROW(with([](auto& o) { o.block_size_mm = 79; }).Validate(), Error);
}

TEST(EvalFemOptions, ValidateThrowsOutOfBounds) {
  EXPECT_NO_THROW(EvalFemOptions{}.Validate());
  EvalFemOptions options;
  options.convergence_refinement = 1.0;
  EXPECT_THROW(options.Validate(), Error);
  options.convergence_refinement = 0.0;
  EXPECT_NO_THROW(options.Validate());
  options.body.thickness_mm = -1;
  EXPECT_THROW(options.Validate(), Error);
}

}  // namespace
}  // namespace tac3d::fem
