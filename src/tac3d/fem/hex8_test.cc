#include "tac3d/fem/hex8.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

Hex8Nodes UnitCube(double dx, double dy, double dz) {
  Hex8Nodes x;
  x << 0, 0, 0, dx, 0, 0, dx, dy, 0, 0, dy, 0, 0, 0, dz, dx, 0, dz, dx, dy, dz, 0, dy, dz;
  return x;
}

Hex8Nodes DistortedElement() {
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> move(-0.15, 0.15);
  Hex8Nodes x = UnitCube(1.0, 1.3, 0.8);
  for (int a = 0; a < 8; ++a) {
    for (int c = 0; c < 3; ++c) x(a, c) += move(rng);
  }
  return x;
}

TEST(Hex8, ShapeFunctionsAreNodalAndPartitionUnity) {
  const Hex8Nodes corners = 2.0 * UnitCube(1, 1, 1) - Hex8Nodes::Ones();
  for (int b = 0; b < 8; ++b) {
    const Eigen::Matrix<double, 8, 1> n = CalcHex8Shape(corners.row(b).transpose());
    for (int a = 0; a < 8; ++a) EXPECT_NEAR(n(a), a == b ? 1.0 : 0.0, 1e-15);
  }
  const Eigen::Vector3d xi(0.3, -0.7, 0.1);
  EXPECT_NEAR(CalcHex8Shape(xi).sum(), 1.0, 1e-15);
  EXPECT_LT(CalcHex8ShapeDerivatives(xi).colwise().sum().cwiseAbs().maxCoeff(), 1e-15);
}

TEST(Hex8, ShapeDerivativesMatchFiniteDifferences) {
  const Eigen::Vector3d xi(0.3, -0.7, 0.1);
  const double h = 1e-6;
  const Eigen::Matrix<double, 8, 3> analytic = CalcHex8ShapeDerivatives(xi);
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d step = h * Eigen::Vector3d::Unit(i);
    const Eigen::Matrix<double, 8, 1> numeric =
        (CalcHex8Shape(xi + step) - CalcHex8Shape(xi - step)) / (2 * h);
    EXPECT_LT((numeric - analytic.col(i)).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(Hex8, StiffnessIsSymmetricWithExactlySixRigidBodyModes) {
  const Hex8Nodes x = DistortedElement();
  const ElasticMaterial material{1.0, 0.48};
  const Hex8Matrix k = CalcHex8Stiffness(x, material);
  EXPECT_LT((k - k.transpose()).cwiseAbs().maxCoeff(), 1e-12 * k.cwiseAbs().maxCoeff());
  // Translations and infinitesimal rotations store no energy.
  for (int mode = 0; mode < 6; ++mode) {
    Hex8Vector u;
    for (int a = 0; a < 8; ++a) {
      const Eigen::Vector3d p = x.row(a).transpose();
      u.segment<3>(3 * a) =
          mode < 3 ? Eigen::Vector3d::Unit(mode) : Eigen::Vector3d::Unit(mode - 3).cross(p).eval();
    }
    EXPECT_LT((k * u).norm(), 1e-12 * k.norm()) << "mode " << mode;
  }
  // B-bar with 2x2x2 deviatoric integration has no spurious zero-energy mode: rank 18.
  // (The dynamic-size solver: the test program compiles it for other tests already.)
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(k);
  const Eigen::VectorXd values = eigen.eigenvalues();
  EXPECT_LT(values.head<6>().cwiseAbs().maxCoeff(), 1e-10 * values(23));
  EXPECT_GT(values(6), 1e-4 * values(23));
}

TEST(Hex8, VolumeChangeIsTheStiffnesssVolumetricPart) {
  const Hex8Nodes x = DistortedElement();
  double volume = 0.0;
  const Hex8Vector volume_change = CalcHex8VolumeChange(x, &volume);
  // A uniform dilatation u = e x changes the volume by 3 e V; a rigid motion does not.
  const double e = 0.01;
  Hex8Vector dilatation, rotation;
  for (int a = 0; a < 8; ++a) {
    dilatation.segment<3>(3 * a) = e * x.row(a).transpose();
    rotation.segment<3>(3 * a) = Eigen::Vector3d(0.2, -0.1, 0.3).cross(x.row(a).transpose());
  }
  EXPECT_NEAR(volume_change.dot(dilatation), 3.0 * e * volume, 1e-14);
  EXPECT_NEAR(volume_change.dot(rotation), 0.0, 1e-14);
  EXPECT_GT(volume, 0.5);
  // K(G, K_bulk) - K(G, K_bulk') = (K_bulk - K_bulk') / V (V b)(V b)^T at the same G.
  const ElasticMaterial soft{1.0, 0.3};
  const double g = soft.shear_modulus();
  const double bulk = 40.0 * g;  // nu = 0.4875
  const ElasticMaterial stiff{9.0 * bulk * g / (3.0 * bulk + g),
                              (3.0 * bulk - 2.0 * g) / (2.0 * (3.0 * bulk + g))};
  const Hex8Matrix difference = CalcHex8Stiffness(x, stiff) - CalcHex8Stiffness(x, soft);
  const Hex8Matrix expected =
      (bulk - soft.bulk_modulus()) / volume * volume_change * volume_change.transpose();
  EXPECT_LT((difference - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(Hex8, StiffnessGivesTheUniaxialStressNodalForces) {
  // A box under uniform sigma_xx = s: the face x = dx carries force s * dy * dz, a quarter a
  // node, for the displacement u_x = s / E x, u_y = -nu s / E y, u_z = -nu s / E z.
  const double dx = 2.0, dy = 1.5, dz = 0.5, s = 0.3;
  const ElasticMaterial material{1.2, 0.45};
  const Hex8Nodes x = UnitCube(dx, dy, dz);
  Hex8Vector u;
  for (int a = 0; a < 8; ++a) {
    u.segment<3>(3 * a) =
        s / material.youngs_modulus_mpa *
        Eigen::Vector3d(
            x(a, 0), -material.poisson_ratio * x(a, 1), -material.poisson_ratio * x(a, 2));
  }
  const Hex8Vector f = CalcHex8Stiffness(x, material) * u;
  for (int a = 0; a < 8; ++a) {
    const double expected = (x(a, 0) > 0 ? 1.0 : -1.0) * s * dy * dz / 4.0;
    EXPECT_NEAR(f(3 * a), expected, 1e-12);
    EXPECT_NEAR(f(3 * a + 1), 0.0, 1e-12);
    EXPECT_NEAR(f(3 * a + 2), 0.0, 1e-12);
  }
}

TEST(Hex8, TopFaceIntegralsOfAFlatFace) {
  const Hex8Nodes x = UnitCube(2.0, 3.0, 1.0);
  const TopFaceIntegrals whole = IntegrateHex8TopFace(x, -1, 1, -1, 1);
  EXPECT_NEAR(whole.area_mm2, 6.0, 1e-12);
  for (int a = 0; a < 4; ++a) EXPECT_NEAR(whole.shape_integrals(a), 1.5, 1e-12);
  // The quarter xi, eta in [0, 1]: area 1.5, mostly on node 6 (xi = eta = 1).
  const TopFaceIntegrals quarter = IntegrateHex8TopFace(x, 0, 1, 0, 1);
  EXPECT_NEAR(quarter.area_mm2, 1.5, 1e-12);
  EXPECT_NEAR(quarter.shape_integrals(2), 1.5 * 0.75 * 0.75, 1e-12);
  EXPECT_NEAR(quarter.shape_integrals(0), 1.5 * 0.25 * 0.25, 1e-12);
}

TEST(Hex8, InvertedElementHasNegativeJacobian) {
  Hex8Nodes x = UnitCube(1, 1, 1);
  x.row(6) = Eigen::RowVector3d(-0.5, -0.5, -0.5);
  EXPECT_LT(CalcHex8MinJacobianDeterminant(x), 0.0);
  EXPECT_GT(CalcHex8MinJacobianDeterminant(DistortedElement()), 0.0);
}

TEST(ElasticMaterial, ModuliOfKnownMaterial) {
  const ElasticMaterial m{1.0, 0.25};
  EXPECT_NEAR(m.shear_modulus(), 0.4, 1e-15);
  EXPECT_NEAR(m.bulk_modulus(), 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(m.constrained_modulus(), 1.2, 1e-15);
}

TEST(ElasticMaterial, ValidateThrowsOutOfBounds) {
  EXPECT_NO_THROW((ElasticMaterial{1.0, 0.4999}.Validate()));
  EXPECT_THROW((ElasticMaterial{0.0, 0.3}.Validate()), Error);
  EXPECT_THROW((ElasticMaterial{-1.0, 0.3}.Validate()), Error);
  EXPECT_THROW((ElasticMaterial{1.0, -1.0}.Validate()), Error);
  EXPECT_THROW((ElasticMaterial{1.0, 0.5}.Validate()), Error);
  EXPECT_THROW((ElasticMaterial{1.0, std::nan("")}.Validate()), Error);
}

}  // namespace
}  // namespace tac3d::fem
