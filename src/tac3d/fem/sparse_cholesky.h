#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace tac3d::fem {

/// The supernodal Cholesky factorisation P K P^T = L L^T of a sparse symmetric positive definite
/// K (CHOLMOD), with the products with K^-1 a compliance needs.
///
/// P is a METIS nested dissection of the graph of K's unknowns grouped into nodes (the three
/// displacements of a mesh node are one vertex), which CHOLMOD then postorders.
class SparseCholesky {
 public:
  /// Analyses and factors K.
  /// @param lower K's lower triangle (compressed columns, each column's rows sorted).
  /// @param node_of node_of[i] the node unknown i belongs to, in [0, number of nodes); the
  ///   ordering keeps a node's unknowns together.
  /// @param name what K is, for error messages ("free-DOF stiffness matrix").
  /// @throws tac3d::Error if CHOLMOD's analysis or factorisation fails (K not positive definite,
  ///   out of memory, its factor too large for 32-bit indices), with CHOLMOD's reason, the stage
  ///   and K's size.
  SparseCholesky(const Eigen::SparseMatrix<double>& lower,
                 const std::vector<int>& node_of,
                 const std::string& name);
  ~SparseCholesky();
  SparseCholesky(SparseCholesky&&) noexcept;
  SparseCholesky& operator=(SparseCholesky&&) noexcept;

  /// K^-1 rhs (CHOLMOD's supernodal solves; concurrent calls take turns).
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& rhs) const;

  /// How CalcBilinear goes about left^T K^-1 right. With K^-1 = P^T L^-T L^-1 P, a forward
  /// solve L^-1 P x of a column x with few non-zeros only reaches the supernodes on the paths
  /// from those non-zeros' supernodes to the root of the supernodal elimination tree, where a
  /// full solve reads all of L twice; columns are solved in blocks, columns whose non-zeros lie
  /// in the same part of the tree together.
  enum class Method {
    /// Whichever of the two below takes fewer flops, counted on the reaches before solving.
    kCheapest,
    /// (L^-1 P left)^T (L^-1 P right): both sides solved forward on their reaches only, the
    /// side with fewer columns kept, and the blocks multiplied where their reaches meet. The
    /// cheaper when both sides are a few thousand local columns (a compliance matrix).
    kBothForward,
    /// One side solved forward on its reach, then backward on the union of the other side's
    /// reaches (all the rows the other side reads and their ancestors), then read by the other
    /// side. The cheaper when one side has many columns or few non-zero rows in all.
    kForwardThenBackward,
  };

  /// left^T K^-1 right.
  /// @param left, right n x p and n x q (n = K's size).
  /// @param block_columns columns solved together (BLAS-3 on the supernodes).
  /// @param on_progress if set, called with the fraction of the blocks done after each.
  /// @return p x q.
  Eigen::MatrixXd CalcBilinear(const Eigen::SparseMatrix<double>& left,
                               const Eigen::SparseMatrix<double>& right,
                               Method method = Method::kCheapest,
                               int block_columns = 100,
                               const std::function<void(double)>& on_progress = {}) const;

  int size() const;
  /// Non-zeros of L and floating-point operations of the factorisation (CHOLMOD's counts).
  double factor_nonzeros() const;
  double factor_flops() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tac3d::fem
