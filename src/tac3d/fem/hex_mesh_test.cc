#include "tac3d/fem/hex_mesh.h"

#include <gtest/gtest.h>

#include <random>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

HexMesh DistortedBox() {
  HexMesh mesh = BuildBoxMesh({0, 1, 2.5, 3}, {0, 0.5, 1, 2}, {-1, 0, 1});
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> move(-0.1, 0.1);
  for (Eigen::Vector3d& p : mesh.nodes) p += Eigen::Vector3d(move(rng), move(rng), move(rng));
  return mesh;
}

TEST(BoxMesh, CountsOrderAndPositiveJacobians) {
  const HexMesh mesh = BuildBoxMesh({0, 1, 2.5, 3}, {0, 0.5, 1, 2}, {-1, 0, 1});
  EXPECT_EQ(mesh.num_nodes(), 4 * 4 * 3);
  EXPECT_EQ(mesh.num_elements(), 3 * 3 * 2);
  EXPECT_EQ(mesh.nodes[(2 * 4 + 1) * 4 + 3], Eigen::Vector3d(3, 0.5, 1));
  // Element (1, 2, 1): its node 6 is node (2, 3, 2).
  EXPECT_EQ(mesh.elements[(1 * 3 + 2) * 3 + 1][6], (2 * 4 + 3) * 4 + 2);
  EXPECT_GT(CalcMinJacobianDeterminant(mesh), 0.0);
}

TEST(BoxMesh, RejectsBadCoordinates) {
  EXPECT_THROW(BuildBoxMesh({0}, {0, 1}, {0, 1}), Error);
  EXPECT_THROW(BuildBoxMesh({0, 1}, {0, 1, 1}, {0, 1}), Error);
  EXPECT_THROW(BuildBoxMesh({0, 1}, {0, 1}, {1, 0}), Error);
}

TEST(InverseMap, RecoversParametricPoints) {
  const HexMesh mesh = DistortedBox();
  const Hex8Nodes x = mesh.ElementNodes(7);
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d xi(coordinate(rng), coordinate(rng), coordinate(rng));
    const Eigen::Vector3d p = x.transpose() * CalcHex8Shape(xi);
    const std::optional<Eigen::Vector3d> found = CalcHex8InverseMap(x, p);
    ASSERT_TRUE(found.has_value());
    EXPECT_THAT(*found, EigenNear(xi, 1e-10));
  }
}

TEST(PointLocator, FindsTheElementAndRejectsOutsidePoints) {
  const HexMesh mesh = DistortedBox();
  const PointLocator locator(mesh);
  const Eigen::Vector3d xi(0.2, -0.4, 0.6);
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const Eigen::Vector3d p = mesh.ElementNodes(e).transpose() * CalcHex8Shape(xi);
    const std::optional<ElementPoint> found = locator.Locate(p);
    ASSERT_TRUE(found.has_value());
    EXPECT_EQ(found->element, e);
    EXPECT_THAT(found->xi, EigenNear(xi, 1e-10));
  }
  EXPECT_FALSE(locator.Locate(Eigen::Vector3d(1.5, 1.0, 1.6)).has_value());
  EXPECT_FALSE(locator.Locate(Eigen::Vector3d(-5, 0, 0)).has_value());
}

TEST(InterpolationMatrix, ReproducesALinearField) {
  const HexMesh mesh = DistortedBox();
  const PointLocator locator(mesh);
  Eigen::Matrix3d a;
  a << 1, 2, 3, -1, 0.5, 0, 0.25, -2, 1;
  Eigen::VectorXd u(mesh.num_dofs());
  for (int n = 0; n < mesh.num_nodes(); ++n) u.segment<3>(3 * n) = a * mesh.nodes[n];
  const std::vector<Eigen::Vector3d> points = {{1.2, 0.7, 0.1}, {2.7, 1.5, -0.6}};
  std::vector<ElementPoint> located;
  for (const Eigen::Vector3d& p : points) located.push_back(*locator.Locate(p));
  const Eigen::VectorXd values = CalcInterpolationMatrix(mesh, located) * u;
  // Rows are component-major: c * P + p.
  for (int p = 0; p < 2; ++p) {
    const Eigen::Vector3d expected = a * points[p];
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(values(c * 2 + p), expected(c), 1e-10);
  }
}

}  // namespace
}  // namespace tac3d::fem
