#include "tac3d/fem/sparse_cholesky.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

using Method = SparseCholesky::Method;

// A symmetric positive definite matrix with the pattern of a 3D grid of nodes (3 unknowns a
// node, coupled to the 26 neighbours), random values, diagonally dominant; unknown i is node
// i / 3's.
struct GridMatrix {
  int nx = 7, ny = 6, nz = 5;
  int num_nodes() const { return nx * ny * nz; }
  Eigen::SparseMatrix<double> full;
  std::vector<int> node_of;

  explicit GridMatrix(double diagonal_margin = 1.0) {
    std::mt19937 random(7);
    std::uniform_real_distribution<double> value(-1.0, 1.0);
    const int n = 3 * num_nodes();
    std::vector<Eigen::Triplet<double>> triplets;
    Eigen::VectorXd row_sums = Eigen::VectorXd::Zero(n);
    const auto node = [&](int i, int j, int k) { return (k * ny + j) * nx + i; };
    for (int k = 0; k < nz; ++k) {
      for (int j = 0; j < ny; ++j) {
        for (int i = 0; i < nx; ++i) {
          for (int dk = 0; dk <= 1; ++dk) {
            for (int dj = -1; dj <= 1; ++dj) {
              for (int di = -1; di <= 1; ++di) {
                const int i2 = i + di, j2 = j + dj, k2 = k + dk;
                if (i2 < 0 || j2 < 0 || i2 >= nx || j2 >= ny || k2 >= nz) continue;
                const int a = node(i, j, k), b = node(i2, j2, k2);
                if (b <= a) continue;
                for (int c = 0; c < 3; ++c) {
                  for (int d = 0; d < 3; ++d) {
                    const double v = value(random);
                    triplets.emplace_back(3 * a + c, 3 * b + d, v);
                    triplets.emplace_back(3 * b + d, 3 * a + c, v);
                    row_sums(3 * a + c) += std::abs(v);
                    row_sums(3 * b + d) += std::abs(v);
                  }
                }
              }
            }
          }
        }
      }
    }
    for (int a = 0; a < num_nodes(); ++a) {  // the couplings within a node
      for (int c = 0; c < 3; ++c) {
        for (int d = c + 1; d < 3; ++d) {
          const double v = value(random);
          triplets.emplace_back(3 * a + c, 3 * a + d, v);
          triplets.emplace_back(3 * a + d, 3 * a + c, v);
          row_sums(3 * a + c) += std::abs(v);
          row_sums(3 * a + d) += std::abs(v);
        }
      }
    }
    for (int i = 0; i < n; ++i) triplets.emplace_back(i, i, row_sums(i) + diagonal_margin);
    full.resize(n, n);
    full.setFromTriplets(triplets.begin(), triplets.end());
    for (int i = 0; i < n; ++i) node_of.push_back(i / 3);
  }

  Eigen::SparseMatrix<double> lower() const { return full.triangularView<Eigen::Lower>(); }
};

// n x count columns, each with `per_column` random non-zeros in rows [first, first + span).
Eigen::SparseMatrix<double> LocalColumns(
    int n, int count, int first, int span, int per_column, int seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> row(first, first + span - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> triplets;
  for (int j = 0; j < count; ++j) {
    for (int t = 0; t < per_column; ++t) triplets.emplace_back(row(random), j, value(random));
  }
  Eigen::SparseMatrix<double> m(n, count);
  m.setFromTriplets(triplets.begin(), triplets.end());
  return m;
}

TEST(SparseCholesky, SolveMatchesADenseFactorisation) {
  const GridMatrix k;
  const SparseCholesky factor(k.lower(), k.node_of, "test matrix");
  EXPECT_EQ(factor.size(), k.full.rows());
  EXPECT_GT(factor.factor_nonzeros(), k.lower().nonZeros());
  const Eigen::MatrixXd rhs = Eigen::MatrixXd::Random(k.full.rows(), 3);
  const Eigen::MatrixXd expected = Eigen::MatrixXd(k.full).llt().solve(rhs);
  EXPECT_THAT(factor.Solve(rhs), EigenNear(expected, 1e-12 * expected.cwiseAbs().maxCoeff()));
}

TEST(SparseCholesky, BilinearMatchesDenseSolvesWithEveryMethod) {
  const GridMatrix k;
  const SparseCholesky factor(k.lower(), k.node_of, "test matrix");
  const int n = static_cast<int>(k.full.rows());
  const Eigen::MatrixXd k_inverse =
      Eigen::MatrixXd(k.full).llt().solve(Eigen::MatrixXd::Identity(n, n));
  // Both sides local (near the first and the last layers), one side wide and the other a
  // single column, and columns anywhere.
  struct Case {
    const char* name;
    Eigen::SparseMatrix<double> left, right;
  };
  const int layer = 3 * k.nx * k.ny;
  Eigen::SparseMatrix<double> with_empty = LocalColumns(n, 9, 0, n, 4, 5);
  with_empty.col(4) *= 0.0;
  with_empty.prune(0.0);
  const std::vector<Case> cases = {
      {"local", LocalColumns(n, 40, 0, layer, 3, 1), LocalColumns(n, 30, n - layer, layer, 5, 2)},
      {"one column", LocalColumns(n, 120, 0, n, 2, 3), LocalColumns(n, 1, layer, layer, 3, 4)},
      {"an empty column", with_empty, LocalColumns(n, 17, 0, n, 1, 6)},
  };
  for (const Case& c : cases) {
    const Eigen::MatrixXd expected =
        Eigen::MatrixXd(c.left).transpose() * k_inverse * Eigen::MatrixXd(c.right);
    const double tolerance = 1e-12 * expected.cwiseAbs().maxCoeff();
    for (const Method method :
         {Method::kCheapest, Method::kBothForward, Method::kForwardThenBackward}) {
      for (const int block : {1, 7, 64}) {
        const Eigen::MatrixXd swapped = factor.CalcBilinear(c.right, c.left, method, block);
        EXPECT_THAT(factor.CalcBilinear(c.left, c.right, method, block),
                    EigenNear(expected, tolerance))
            << c.name << ", method " << static_cast<int>(method) << ", blocks of " << block;
        EXPECT_THAT(swapped, EigenNear(Eigen::MatrixXd(expected.transpose()), tolerance))
            << c.name << " swapped, method " << static_cast<int>(method) << ", blocks of " << block;
      }
    }
  }
  // No columns on a side: an empty product.
  const Eigen::MatrixXd none =
      factor.CalcBilinear(Eigen::SparseMatrix<double>(n, 0), LocalColumns(n, 3, 0, n, 2, 8));
  EXPECT_EQ(none.rows(), 0);
  EXPECT_EQ(none.cols(), 3);
}

TEST(SparseCholesky, ProgressReachesOne) {
  const GridMatrix k;
  const SparseCholesky factor(k.lower(), k.node_of, "test matrix");
  const int n = static_cast<int>(k.full.rows());
  for (const Method method : {Method::kBothForward, Method::kForwardThenBackward}) {
    std::vector<double> reported;
    factor.CalcBilinear(LocalColumns(n, 20, 0, n, 2, 1),
                        LocalColumns(n, 20, 0, n, 2, 2),
                        method,
                        8,
                        [&](double done) { reported.push_back(done); });
    ASSERT_FALSE(reported.empty());
    EXPECT_TRUE(std::is_sorted(reported.begin(), reported.end()));
    EXPECT_DOUBLE_EQ(reported.back(), 1.0);
  }
}

TEST(SparseCholesky, ThrowsWhenNotPositiveDefinite) {
  const GridMatrix indefinite(-1e3);
  EXPECT_THAT([&] { SparseCholesky(indefinite.lower(), indefinite.node_of, "test matrix"); },
              ::testing::ThrowsMessage<Error>(::testing::AllOf(
                  ::testing::HasSubstr("factorisation of the 630 x 630 test matrix"),
                  ::testing::HasSubstr("not positive definite"))));
}

}  // namespace
}  // namespace tac3d::fem
