#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

#include "tac3d/fem/hex8.h"
#include "tac3d/fem/hex_mesh.h"

namespace tac3d::fem {

/// What building an ElasticSolver cost.
struct ElasticSolverSummary {
  int num_free_dofs = 0;
  int num_fixed_dofs = 0;
  /// Non-zeros of the lower triangle of the free-DOF stiffness matrix.
  long stiffness_nonzeros = 0;
  /// Non-zeros of the Cholesky factor L and floating-point operations of the factorisation
  /// (CHOLMOD's statistics, for the ordering it chose).
  double factor_nonzeros = 0.0;
  double factor_flops = 0.0;
  double assembly_s = 0.0;
  double factorization_s = 0.0;
};

/// Linear elastic statics on a hex8 mesh (B-bar elements, CalcHex8Stiffness): assembles the
/// stiffness of the free DOFs and factors it once (CHOLMOD supernodal LL^T), then solves any
/// number of load cases. Displacements are mm, forces N, DOFs node-major (HexMesh).
class ElasticSolver {
 public:
  /// @param fixed one flag a DOF (size mesh.num_dofs()): true where the displacement is
  ///   prescribed (zero unless Solve is given values).
  /// @param show_progress a tac3d::ProgressBar on stderr for assembly and factorisation.
  /// @throws tac3d::Error if the material is invalid, `fixed` has the wrong size, or the
  ///   constraints leave a rigid-body motion free (the stiffness is singular).
  /// @pre every element has a positive Jacobian (TAC3D_DEMAND).
  ElasticSolver(const HexMesh& mesh,
                const ElasticMaterial& material,
                const std::vector<bool>& fixed,
                bool show_progress = false);
  ~ElasticSolver();
  ElasticSolver(ElasticSolver&&) noexcept;
  ElasticSolver& operator=(ElasticSolver&&) noexcept;

  /// Nodal displacements (mm, size num_dofs) for nodal forces (N, size num_dofs; the entries
  /// at fixed DOFs are reactions and ignored) and, optionally, the displacements of the fixed
  /// DOFs (mm, size num_dofs, read at fixed DOFs only; empty = all zero).
  Eigen::VectorXd Solve(const Eigen::VectorXd& nodal_forces,
                        const Eigen::VectorXd& prescribed = Eigen::VectorXd()) const;

  /// readout * u(nodal_forces) for many load cases with the fixed DOFs at zero, solved
  /// `chunk_columns` load cases at a time so the full displacement fields never coexist.
  /// @param readout rows x num_dofs, e.g. a CalcInterpolationMatrix.
  /// @param nodal_forces num_dofs x cases (N).
  /// @param show_progress a tac3d::ProgressBar over the chunks.
  /// @return rows x cases.
  Eigen::MatrixXd CalcResponse(const Eigen::SparseMatrix<double>& readout,
                               const Eigen::SparseMatrix<double>& nodal_forces,
                               bool show_progress = false,
                               int chunk_columns = 100) const;

  int num_dofs() const;
  const ElasticSolverSummary& summary() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tac3d::fem
