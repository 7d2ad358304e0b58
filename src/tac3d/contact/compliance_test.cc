#include "tac3d/contact/compliance.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <numbers>
#include <random>
#include <utility>

#include "tac3d/fem/evaluation.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

ElasticMaterial Silicone() { return {1.0, 0.48}; }

Eigen::MatrixXd RandomTraction(int rows, int cols, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < m.size(); ++i) m.data()[i] = u(rng);
  return m;
}

TEST(SurfaceGrid, IsCentredAndRejectsTooSmallGrids) {
  const SurfaceGrid grid{5, 3, 0.5, 0.25};
  EXPECT_NO_THROW(grid.Validate());
  EXPECT_TRUE(grid.node_position_mm(0).isApprox(Eigen::Vector2d(-1.0, -0.25)));
  EXPECT_TRUE(grid.node_position_mm(7).isZero());  // (2, 1), the centre
  EXPECT_FALSE(grid.is_edge_node(7));
  EXPECT_TRUE(grid.is_edge_node(9));  // (4, 1)
  EXPECT_THROW((SurfaceGrid{2, 5, 1.0, 1.0}.Validate()), Error);
  EXPECT_THROW((SurfaceGrid{5, 2, 1.0, 1.0}.Validate()), Error);
  EXPECT_THROW((SurfaceGrid{5, 5, 0.0, 1.0}.Validate()), Error);
  EXPECT_THROW((SurfaceGrid{5, 5, 1.0, NAN}.Validate()), Error);
}

// The displacement at the centre of a uniformly loaded square of side s:
// (1 - nu^2) / (pi E) 4 s ln(1 + sqrt 2) (Love 1929; Johnson, Contact Mechanics, ch. 3).
TEST(HalfSpaceInfluence, CentreOfASquareIsLovesValue) {
  const ElasticMaterial m = Silicone();
  const double s = 0.3;
  const double exact = (1.0 - m.poisson_ratio * m.poisson_ratio) /
                       (std::numbers::pi * m.youngs_modulus_mpa) * 4.0 * s *
                       std::log(1.0 + std::sqrt(2.0));
  EXPECT_NEAR(CalcHalfSpaceInfluence(2, 2, 0.0, 0.0, s, s, m), exact, 1e-14);
  // By symmetry the centre does not move sideways.
  EXPECT_NEAR(CalcHalfSpaceInfluence(0, 2, 0.0, 0.0, s, s, m), 0.0, 1e-15);
  EXPECT_NEAR(CalcHalfSpaceInfluence(0, 1, 0.0, 0.0, s, s, m), 0.0, 1e-15);
}

// Far from the cell, every coefficient is the point-load solution of the FEM's oracle
// (fem::CalcHalfSpaceSurfaceDisplacement, z out of the body) for the cell's force.
TEST(HalfSpaceInfluence, FarFieldIsBoussinesqAndCerruti) {
  const ElasticMaterial m = Silicone();
  const double dx = 0.2, dy = 0.15;
  const Eigen::Vector2d offset(12 * dx, -7 * dy);
  for (int in = 0; in < 3; ++in) {
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    force[in] = dx * dy;
    if (in == 2) force[2] = -dx * dy;  // a pressure pushes into the body
    Eigen::Vector3d point = fem::CalcHalfSpaceSurfaceDisplacement(force, m, offset);
    point.z() = -point.z();  // normal displacement positive into the body
    for (int out = 0; out < 3; ++out) {
      const double cell = CalcHalfSpaceInfluence(out, in, offset.x(), offset.y(), dx, dy, m);
      EXPECT_NEAR(cell, point[out], 2e-3 * point.cwiseAbs().maxCoeff())
          << "out " << out << " in " << in;
    }
  }
}

TEST(HalfSpaceCompliance, FftEqualsTheDirectSum) {
  const SurfaceGrid grid{7, 9, 0.3, 0.2};
  const HalfSpaceCompliance c(grid, {2.0, 0.3});
  const Eigen::MatrixXd dense = c.CalcDenseMatrix();
  std::mt19937_64 rng(testing::kRandomSeed);
  const int n = grid.num_nodes();
  const Eigen::MatrixXd p = RandomTraction(n, 3, rng);
  const Eigen::Map<const Eigen::VectorXd> p_all(p.data(), 3 * n);
  const Eigen::VectorXd u_all = dense * p_all;
  const Eigen::MatrixXd pt = p.leftCols(2), pn = p.col(2);
  const Eigen::MatrixXd ut = c.Apply(Components::kTangential, Components::kTangential, pt) +
                             c.Apply(Components::kTangential, Components::kNormal, pn);
  const Eigen::MatrixXd un = c.Apply(Components::kNormal, Components::kTangential, pt) +
                             c.Apply(Components::kNormal, Components::kNormal, pn);
  const double tol = 1e-12 * u_all.cwiseAbs().maxCoeff();
  EXPECT_THAT(Eigen::MatrixXd(ut.col(0)), EigenNear(Eigen::MatrixXd(u_all.segment(0, n)), tol));
  EXPECT_THAT(Eigen::MatrixXd(ut.col(1)), EigenNear(Eigen::MatrixXd(u_all.segment(n, n)), tol));
  EXPECT_THAT(un, EigenNear(Eigen::MatrixXd(u_all.segment(2 * n, n)), tol));
}

TEST(ConvolutionCompliance, AWindowIsTheOperatorOnAnyBlockOfItsNodes) {
  const SurfaceGrid grid{9, 8, 0.3, 0.2};
  const HalfSpaceCompliance c(grid, {2.0, 0.3});
  const std::shared_ptr<const ComplianceOperator> window = c.Window(5, 4);
  ASSERT_NE(window, nullptr);
  EXPECT_EQ(window->grid().nx, 5);
  EXPECT_EQ(window->grid().ny, 4);
  EXPECT_EQ(window->grid().dx_mm, grid.dx_mm);
  std::mt19937_64 rng(testing::kRandomSeed);
  const Eigen::MatrixXd t = RandomTraction(20, 3, rng);
  for (const auto& [i0, j0] : {std::pair{0, 0}, std::pair{4, 4}, std::pair{2, 1}}) {
    // The traction on the block, zero elsewhere: the grid's displacements on the block are the
    // window's.
    Eigen::MatrixXd on_grid = Eigen::MatrixXd::Zero(grid.num_nodes(), 3);
    for (int k = 0; k < 20; ++k) on_grid.row((j0 + k / 5) * grid.nx + i0 + k % 5) = t.row(k);
    for (Components out : {Components::kTangential, Components::kNormal}) {
      for (Components in : {Components::kTangential, Components::kNormal}) {
        const bool normal = in == Components::kNormal;
        const Eigen::MatrixXd tin = normal ? t.rightCols(1) : t.leftCols(2);
        const Eigen::MatrixXd gin = normal ? on_grid.rightCols(1) : on_grid.leftCols(2);
        const Eigen::MatrixXd u_window = window->Apply(out, in, tin);
        const Eigen::MatrixXd u_grid = c.Apply(out, in, gin);
        Eigen::MatrixXd u_block(20, u_grid.cols());
        for (int k = 0; k < 20; ++k) u_block.row(k) = u_grid.row((j0 + k / 5) * grid.nx + i0 + k % 5);
        EXPECT_THAT(u_window, EigenNear(u_block, 1e-12 * u_block.cwiseAbs().maxCoeff()))
            << "block at " << i0 << ", " << j0;
      }
    }
  }
  // A dense matrix need not be the same on every block: no windows.
  EXPECT_EQ(DenseCompliance(grid, c.CalcDenseMatrix()).Window(5, 4), nullptr);
}

TEST(HalfSpaceCompliance, IsSymmetricPositiveDefiniteAndDrawsTheSurfaceInward) {
  const SurfaceGrid grid{5, 5, 0.25, 0.25};
  const Eigen::MatrixXd c = HalfSpaceCompliance(grid, Silicone()).CalcDenseMatrix();
  EXPECT_LE((c - c.transpose()).cwiseAbs().maxCoeff(), 1e-14 * c.cwiseAbs().maxCoeff());
  EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(c).info(), Eigen::Success);
  // Pressure on the centre cell (12) pulls the node to its right (13) towards it (-x) and
  // pushes it into the body; a traction along +x presses the surface in ahead of it.
  const int n = grid.num_nodes();
  EXPECT_LT(c(0 * n + 13, 2 * n + 12), 0.0);
  EXPECT_GT(c(2 * n + 13, 2 * n + 12), 0.0);
  EXPECT_GT(c(2 * n + 13, 0 * n + 12), 0.0);
  EXPECT_LT(c(2 * n + 11, 0 * n + 12), 0.0);
}

TEST(DenseCompliance, AppliesItsBlocksAndRejectsBadMatrices) {
  const SurfaceGrid grid{3, 4, 0.5, 0.5};
  const int n = grid.num_nodes();
  const Eigen::MatrixXd matrix = HalfSpaceCompliance(grid, Silicone()).CalcDenseMatrix();
  const DenseCompliance c(grid, matrix);
  std::mt19937_64 rng(testing::kRandomSeed);
  const Eigen::MatrixXd q = RandomTraction(n, 2, rng);
  const Eigen::Map<const Eigen::VectorXd> q_all(q.data(), 2 * n);
  const Eigen::VectorXd un = matrix.block(2 * n, 0, n, 2 * n) * q_all;
  EXPECT_THAT(c.Apply(Components::kNormal, Components::kTangential, q),
              EigenNear(Eigen::MatrixXd(un), 1e-15));

  EXPECT_THROW(DenseCompliance(grid, Eigen::MatrixXd::Identity(3 * n - 1, 3 * n - 1)), Error);
  Eigen::MatrixXd asymmetric = matrix;
  asymmetric(0, 1) += 1e-3 * matrix.maxCoeff();
  EXPECT_THROW(DenseCompliance(grid, asymmetric), Error);
  Eigen::MatrixXd nan = matrix;
  nan(2, 2) = NAN;
  EXPECT_THROW(DenseCompliance(grid, nan), Error);
  EXPECT_THROW(DenseCompliance(SurfaceGrid{2, 6, 0.5, 0.5}, matrix), Error);
}

TEST(HalfSpaceCompliance, RejectsABadGridOrMaterial) {
  EXPECT_THROW(HalfSpaceCompliance(SurfaceGrid{2, 2, 0.1, 0.1}, Silicone()), Error);
  EXPECT_THROW(HalfSpaceCompliance(SurfaceGrid{5, 5, 0.1, 0.1}, ElasticMaterial{-1.0, 0.3}),
               Error);
}

}  // namespace
}  // namespace tac3d::contact
