#include "tac3d/fem/compliance_family.h"

#include <gtest/gtest.h>

#include "tac3d/fem/compliance.h"
#include "tac3d/fem/test_domes.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

// The shared small dome (3 x 4 markers) of the given material.
BodyModelOptions SmallDome(double poisson_ratio, double youngs_modulus_mpa = 1.0) {
  BodyModelOptions options = testing::SmallDome();
  options.material = {youngs_modulus_mpa, poisson_ratio};
  return options;
}

double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / b.norm();
}

const std::vector<double> kNodes = {0.40, 0.45, 0.48, 0.499};

TEST(ComplianceFamily, HScalesExactlyAsOneOverYoungsModulus) {
  const Eigen::MatrixXd soft = CalcComplianceModel(SmallDome(0.45, 1.0)).h;
  const Eigen::MatrixXd stiff = CalcComplianceModel(SmallDome(0.45, 2.5)).h;
  EXPECT_LT(RelativeDifference(2.5 * stiff, soft), 1e-10);
}

TEST(ComplianceFamily, ReturnsTheNodesThemselves) {
  const ComplianceFamily family(SmallDome(0.48), kNodes, "");
  const Eigen::MatrixXd direct = CalcComplianceModel(SmallDome(0.45, 1.7)).h;
  EXPECT_LT(RelativeDifference(family.CalcH({1.7, 0.45}), direct), 1e-10);
}

// Between the nodes the interpolation in G / K is far closer to a direct build than the FEM is
// to its own refinement (H changes 1.6% on 1.5x refinement, docs/fem.md).
TEST(ComplianceFamily, InterpolatesBetweenTheNodesInShearToBulkRatio) {
  const ComplianceFamily family(SmallDome(0.48), kNodes, "");
  for (double nu : {0.42, 0.432, 0.465, 0.49}) {
    const Eigen::MatrixXd direct = CalcComplianceModel(SmallDome(nu, 1.3)).h;
    const double error = RelativeDifference(family.CalcH({1.3, nu}), direct);
    std::printf("nu %.3f: relative Frobenius error %.2e\n", nu, error);
    EXPECT_LT(error, 1e-3) << "nu " << nu;
  }
}

TEST(ComplianceFamily, RefusesToExtrapolate) {
  const ComplianceFamily family(SmallDome(0.48), {0.45, 0.48}, "");
  EXPECT_THROW(family.CalcH({1.0, 0.44}), Error);
  EXPECT_THROW(family.CalcH({1.0, 0.49}), Error);
  EXPECT_NO_THROW(family.CalcH({1.0, 0.46}));
}

TEST(ComplianceFamily, NeedsTwoDistinctNodes) {
  EXPECT_THROW(ComplianceFamily(SmallDome(0.48), {0.45}, ""), Error);
  EXPECT_THROW(ComplianceFamily(SmallDome(0.48), {0.45, 0.45}, ""), Error);
  EXPECT_THROW(ComplianceFamily(SmallDome(0.48), {0.45, 0.5}, ""), Error);
}

}  // namespace
}  // namespace tac3d::fem
