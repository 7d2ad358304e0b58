#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

#include "tac3d/fem/hex8.h"
#include "tac3d/fem/hex_mesh.h"

namespace tac3d::fem {

/// How an ElasticSolver solves K u = f.
enum class ElasticSolverMethod {
  /// CHOLMOD supernodal LL^T of K (SparseCholesky: METIS on the mesh nodes), exact to
  /// rounding; memory and time grow steeply with the mesh (refinement 1.5 of the default dome:
  /// 559,482 DOFs, a 5 GB factor).
  kDirect,
  /// Conjugate gradients on K, preconditioned by a two-grid cycle whose coarse level is a
  /// coarser mesh of the same body, factored directly. K is stored once (lower triangle).
  kTwoGridPcg,
  /// PcgOptions::mixed_form, for nearly incompressible materials: the equivalent mixed form with
  /// one pressure an element, K_bulk split into r + (K_bulk - r),
  ///   [A_r  B^T; B  -M / (K_bulk - r)] [u; p] = [f; 0],  A_r = G S_dev + r S_vol,
  /// B the elements' volume-change rows (CalcHex8VolumeChange), M = diag(V_e); eliminating p
  /// gives K u = f exactly. MINRES with the block-diagonal preconditioner diag(two-grid cycle on
  /// A_r, M (1 / (4G/3 + r) + 1 / (K_bulk - r))); it stops on the residual of K u = f.
  kTwoGridMixedMinres,
};

/// The iteration of ElasticSolverMethod::kTwoGridPcg and kTwoGridMixedMinres.
struct PcgOptions {
  /// Each load case stops when ||f - K u|| <= relative_tolerance ||f|| (free DOFs; the true
  /// residual, recomputed at the end, not only the recurrence's).
  double relative_tolerance = 1e-8;
  /// Iterations a load case may take before the solve throws.
  int max_iterations = 300;
  /// Symmetric Gauss-Seidel sweeps before (forward) and after (backward) the coarse correction.
  int smoothing_sweeps = 3;
  /// Load cases iterated together (one sparse matrix times a block of vectors serves all of
  /// them); each costs 8 vectors of num_free_dofs doubles.
  int block_columns = 32;
  /// Threads a block's load cases are split over, each thread iterating its own share (each
  /// case's iteration is independent of the others', so only rounding in the coarse factor's
  /// solve can differ); 0 = one a hardware thread.
  int threads = 0;
  /// Solve by MINRES on the mixed form (kTwoGridMixedMinres) instead of conjugate gradients on
  /// K (kTwoGridPcg). Off by default: on the small test dome (6,855 free DOFs) the largest
  /// iteration counts were PCG 115 / 376 and MINRES 159 / 222 at nu 0.499 / 0.4999, and on the
  /// default sensor at refinement 2, nu 0.499, MINRES had not converged when stopped after
  /// about the time PCG took to converge (docs/fem.md).
  bool mixed_form = false;
  /// r / G, the share of the bulk modulus kept in A_r (mixed form; r at most K_bulk / 2): A_r
  /// then behaves as a material of K_bulk / G = mixed_bulk_split (30: nu 0.483), which the
  /// two-grid cycle still handles in ~25-35 iterations, while a larger r brings the pressure
  /// block closer to M / r.
  double mixed_bulk_split = 30.0;

  /// @throws tac3d::Error naming the field: tolerance in (0, 1), every count >= 1 (threads
  ///   >= 0), mixed_bulk_split > 0.
  void Validate() const;
};

/// What building an ElasticSolver cost.
struct ElasticSolverSummary {
  ElasticSolverMethod method = ElasticSolverMethod::kDirect;
  int num_free_dofs = 0;
  int num_fixed_dofs = 0;
  /// Non-zeros of the lower triangle of the free-DOF stiffness matrix.
  long stiffness_nonzeros = 0;
  /// Free DOFs of the coarse level (kTwoGridPcg, kTwoGridMixedMinres), 0 for kDirect.
  int coarse_free_dofs = 0;
  /// Pressure unknowns, one an element (kTwoGridMixedMinres), else 0.
  int num_pressures = 0;
  /// Non-zeros of the Cholesky factor L and floating-point operations of the factorisation
  /// (CHOLMOD's statistics, for the ordering it chose), of the coarse level if iterative.
  double factor_nonzeros = 0.0;
  double factor_flops = 0.0;
  /// Assembly of the stiffness (and, if iterative, of the coarse stiffness and B).
  double assembly_s = 0.0;
  /// The Cholesky factorisation (of the coarse level if iterative).
  double factorization_s = 0.0;
};

/// What a Solve or CalcResponse cost, one entry per load case (the iterative methods; empty
/// for kDirect).
struct SolveSummary {
  std::vector<int> iterations;
  /// ||f - K u|| / ||f|| on the free DOFs at the end (0 for a zero load).
  std::vector<double> relative_residuals;
  double solve_s = 0.0;
};

/// Linear elastic statics on a hex8 mesh (B-bar elements, CalcHex8Stiffness): assembles the
/// stiffness of the free DOFs once, then solves any number of load cases, either with a
/// Cholesky factor (kDirect), by two-grid preconditioned conjugate gradients (kTwoGridPcg) or,
/// if asked, by MINRES on the equivalent mixed form (kTwoGridMixedMinres).
/// Displacements are mm, forces N, DOFs node-major (HexMesh).
class ElasticSolver {
 public:
  /// The direct solver: factors the stiffness once (CHOLMOD supernodal LL^T).
  /// @param fixed one flag a DOF (size mesh.num_dofs()): true where the displacement is
  ///   prescribed (zero unless Solve is given values).
  /// @param show_progress a tac3d::ProgressBar on stderr for assembly and factorisation.
  /// @throws tac3d::Error if the material is invalid, `fixed` has the wrong size, the
  ///   constraints leave a rigid-body motion free (the stiffness is not positive definite), or
  ///   CHOLMOD cannot factor the matrix (too large for its 32-bit indices, out of memory); the
  ///   message gives CHOLMOD's reason and the matrix's size.
  /// @pre every element has a positive Jacobian (TAC3D_DEMAND).
  ElasticSolver(const HexMesh& mesh,
                const ElasticMaterial& material,
                const std::vector<bool>& fixed,
                bool show_progress = false);
  /// The iterative solver: kTwoGridPcg, or kTwoGridMixedMinres if options.mixed_form (then A_r
  /// takes K's place below). K is kept; the coarse
  /// level's operator is the Galerkin P^T K P, factored as by the direct constructor (the coarse
  /// mesh gives its DOFs and P). Each preconditioner application is a
  /// symmetric two-grid cycle, so the preconditioner is symmetric positive definite:
  /// `smoothing_sweeps` forward Gauss-Seidel sweeps on K e = r from e = 0, the coarse
  /// correction e += P (P^T K P)^-1 P^T (r - K e), the same number of backward sweeps (e.g.
  /// Trottenberg, Oosterlee, Schueller, Multigrid, 2001, sections 2.4 and 7.8).
  /// @param coarse_mesh, coarse_fixed a coarser mesh of the same body and its fixed-DOF flags.
  /// @param prolongation P, the interpolation of coarse nodal displacements at the fine nodes:
  ///   mesh.num_dofs() x coarse_mesh.num_dofs() (rows and columns at fixed DOFs are ignored).
  /// @throws tac3d::Error as the direct constructor (for either level), if the options are
  ///   invalid, or if the sizes of coarse_fixed or prolongation do not match.
  ElasticSolver(const HexMesh& mesh,
                const ElasticMaterial& material,
                const std::vector<bool>& fixed,
                const HexMesh& coarse_mesh,
                const std::vector<bool>& coarse_fixed,
                const Eigen::SparseMatrix<double>& prolongation,
                const PcgOptions& options,
                bool show_progress = false);
  ~ElasticSolver();
  ElasticSolver(ElasticSolver&&) noexcept;
  ElasticSolver& operator=(ElasticSolver&&) noexcept;

  /// Nodal displacements (mm, size num_dofs) for nodal forces (N, size num_dofs; the entries
  /// at fixed DOFs are reactions and ignored) and, optionally, the displacements of the fixed
  /// DOFs (mm, size num_dofs, read at fixed DOFs only; empty = all zero).
  /// @param summary if not null, the iterations and residual are appended to it (iterative).
  /// @throws tac3d::Error if the iteration does not converge within max_iterations.
  Eigen::VectorXd Solve(const Eigen::VectorXd& nodal_forces,
                        const Eigen::VectorXd& prescribed = Eigen::VectorXd(),
                        SolveSummary* summary = nullptr) const;

  /// readout * u(nodal_forces) for many load cases with the fixed DOFs at zero.
  /// kDirect: readout K^-1 nodal_forces without a full solve a case
  /// (SparseCholesky::CalcBilinear: forward solves restricted to the part of the factor the
  /// loads and the readout reach, `chunk_columns` columns at a time). Iterative:
  /// `chunk_columns` load cases at a time (at most PcgOptions::block_columns, the chunks of
  /// equal size) so the full displacement fields never coexist.
  /// @param readout rows x num_dofs, e.g. a CalcInterpolationMatrix.
  /// @param nodal_forces num_dofs x cases (N).
  /// @param show_progress a tac3d::ProgressBar over the chunks (kDirect: in percent).
  /// @param summary if not null, the iterations and residuals are appended to it (iterative).
  /// @return rows x cases.
  /// @throws tac3d::Error if the iteration does not converge within max_iterations.
  Eigen::MatrixXd CalcResponse(const Eigen::SparseMatrix<double>& readout,
                               const Eigen::SparseMatrix<double>& nodal_forces,
                               bool show_progress = false,
                               int chunk_columns = 100,
                               SolveSummary* summary = nullptr) const;

  int num_dofs() const;
  const ElasticSolverSummary& summary() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tac3d::fem
