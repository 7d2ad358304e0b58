#include "tac3d/fem/elastic_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <thread>

#include "tac3d/fem/sparse_cholesky.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::fem {
namespace {

// For each node, the sorted nodes it shares an element with (itself included).
std::vector<std::vector<int>> NodeNeighbours(const HexMesh& mesh) {
  std::vector<std::vector<int>> neighbours(mesh.num_nodes());
  for (const auto& element : mesh.elements) {
    for (int a : element) neighbours[a].insert(neighbours[a].end(), element.begin(), element.end());
  }
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return neighbours;
}

// Load cases as rows of a row-major block: the c-th value of every DOF is contiguous, so the
// sparse kernels below stream K once for all cases.
using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Y = K X for K stored as its lower triangle (CSC, the diagonal first in each column).
void MultiplySymmetric(const Eigen::SparseMatrix<double>& k, const Block& x, Block* y) {
  const int n = static_cast<int>(k.cols()), m = static_cast<int>(x.cols());
  const int* outer = k.outerIndexPtr();
  const int* inner = k.innerIndexPtr();
  const double* value = k.valuePtr();
  y->setZero(n, m);
  const auto row = [m](auto& block, int i) { return block.data() + static_cast<long>(i) * m; };
  for (int j = 0; j < n; ++j) {
    const double* xj = row(x, j);
    double* yj = row(*y, j);
    for (int c = 0; c < m; ++c) yj[c] += value[outer[j]] * xj[c];
    for (int p = outer[j] + 1; p < outer[j + 1]; ++p) {
      const double* xi = row(x, inner[p]);
      double* yi = row(*y, inner[p]);
      for (int c = 0; c < m; ++c) {
        yj[c] += value[p] * xi[c];
        yi[c] += value[p] * xj[c];
      }
    }
  }
}

// One Gauss-Seidel sweep on K X = B in place, DOFs in increasing (forward) or decreasing order.
// Column i of the lower triangle holds row i of the upper one, so the forward sweep gathers the
// not-yet-updated unknowns from it and scatters the new one to later rows through `work`
// (B minus the lower part times the new X); the backward sweep subtracts the lower part times
// the old X first, then gathers the already-updated unknowns.
void GaussSeidelSweep(
    const Eigen::SparseMatrix<double>& k, const Block& b, bool forward, Block* x, Block* work) {
  const int n = static_cast<int>(k.cols()), m = static_cast<int>(b.cols());
  const int* outer = k.outerIndexPtr();
  const int* inner = k.innerIndexPtr();
  const double* value = k.valuePtr();
  *work = b;
  const auto row = [m](auto& block, int i) { return block.data() + static_cast<long>(i) * m; };
  if (!forward) {
    for (int j = 0; j < n; ++j) {
      for (int p = outer[j] + 1; p < outer[j + 1]; ++p) {
        double* wi = row(*work, inner[p]);
        const double* xj = row(*x, j);
        for (int c = 0; c < m; ++c) wi[c] -= value[p] * xj[c];
      }
    }
  }
  for (int step = 0; step < n; ++step) {
    const int i = forward ? step : n - 1 - step;
    double* xi = row(*x, i);
    double* wi = row(*work, i);
    for (int p = outer[i] + 1; p < outer[i + 1]; ++p) {
      const double* xr = row(*x, inner[p]);
      for (int c = 0; c < m; ++c) wi[c] -= value[p] * xr[c];
    }
    for (int c = 0; c < m; ++c) xi[c] = wi[c] / value[outer[i]];
    if (forward) {
      for (int p = outer[i] + 1; p < outer[i + 1]; ++p) {
        double* wr = row(*work, inner[p]);
        for (int c = 0; c < m; ++c) wr[c] -= value[p] * xi[c];
      }
    }
  }
}

// Column-wise dot products of two blocks.
Eigen::VectorXd ColumnDots(const Block& a, const Block& b) {
  Eigen::VectorXd dots = Eigen::VectorXd::Zero(a.cols());
  for (Eigen::Index i = 0; i < a.rows(); ++i) dots += a.row(i).cwiseProduct(b.row(i)).transpose();
  return dots;
}

// The lower triangle of the Galerkin coarse operator P^T K P, from K's lower triangle L:
// K = L + L^T - D, so P^T K P = X + X^T - P^T D P with X = P^T L P.
Eigen::SparseMatrix<double> GalerkinLower(const Eigen::SparseMatrix<double>& lower,
                                          const Eigen::SparseMatrix<double>& p) {
  const Eigen::SparseMatrix<double> half = p.transpose() * (lower * p);
  const Eigen::VectorXd diagonal = lower.diagonal();
  const Eigen::SparseMatrix<double> diagonal_part = p.transpose() * diagonal.asDiagonal() * p;
  const Eigen::SparseMatrix<double> full =
      half + Eigen::SparseMatrix<double>(half.transpose()) - diagonal_part;
  return full.triangularView<Eigen::Lower>();
}

// Load cases of the mixed form: displacements (free DOFs) and pressures (elements).
struct MixedBlock {
  Block u;
  Block p;
};

Eigen::VectorXd ColumnDots(const MixedBlock& a, const MixedBlock& b) {
  return ColumnDots(a.u, b.u) + ColumnDots(a.p, b.p);
}

// y += x a, one factor a column.
void AddScaled(const MixedBlock& x, const Eigen::VectorXd& a, MixedBlock* y) {
  y->u.noalias() += x.u * a.asDiagonal();
  y->p.noalias() += x.p * a.asDiagonal();
}

// x = x a, one factor a column.
void ScaleColumns(const Eigen::VectorXd& a, MixedBlock* x) {
  x->u = x->u * a.asDiagonal();
  x->p = x->p * a.asDiagonal();
}

// The material with the same shear modulus and the given bulk modulus (MPa).
ElasticMaterial WithBulkModulus(const ElasticMaterial& material, double bulk) {
  const double g = material.shear_modulus();
  return ElasticMaterial{9.0 * bulk * g / (3.0 * bulk + g),
                         (3.0 * bulk - 2.0 * g) / (2.0 * (3.0 * bulk + g))};
}

}  // namespace

struct ElasticSolver::Impl {
  int num_dofs = 0;
  std::vector<int> free_index;                       // DOF -> free-DOF index, or -1
  std::vector<int> fixed_index;                      // DOF -> fixed-DOF index, or -1
  Eigen::SparseMatrix<double> selection;             // num_dofs x free: embeds free DOFs
  Eigen::SparseMatrix<double> stiffness_free_fixed;  // K_fp
  std::unique_ptr<SparseCholesky> factor;            // kDirect, and the coarse level's
  // The iterative methods: the lower triangle of K_ff, the coarse level (its DOF maps and the
  // factor of the Galerkin operator P^T K_ff P), P on the free DOFs.
  Eigen::SparseMatrix<double> stiffness_lower;
  std::unique_ptr<Impl> coarse;
  Eigen::SparseMatrix<double> prolongation;
  PcgOptions pcg;
  // kTwoGridMixedMinres: stiffness_lower and the coarse level hold A_r; B on the free DOFs,
  // M = diag(V_e), K_bulk - r, and the pressure block of the preconditioner as a multiple of M.
  Eigen::SparseMatrix<double, Eigen::RowMajor> volume_change;
  Eigen::VectorXd element_volume;
  double bulk_excess = 0.0;
  double pressure_preconditioner = 0.0;
  ElasticSolverSummary summary;

  // Assembles K_ff (returned, lower triangle) and K_fp, and the DOF maps.
  Eigen::SparseMatrix<double> Assemble(const HexMesh& mesh,
                                       const ElasticMaterial& material,
                                       const std::vector<bool>& fixed,
                                       bool show_progress);
  void Factor(const Eigen::SparseMatrix<double>& k, bool show_progress);
  // K_ff^-1 rhs for free-DOF right-hand sides (columns).
  Eigen::MatrixXd SolveFree(const Eigen::MatrixXd& rhs, SolveSummary* summary) const;
  // Z = B R, one two-grid cycle on each column.
  void Precondition(const Block& r, Block* z, Block* work, Block* scratch) const;
  // The error thrown when load case `c` of `m` has not converged within max_iterations.
  Error NotConverged(int c, int m, double residual, int iterations) const;
  // Two-grid PCG on the columns of rhs; x holds the solutions on return.
  void SolvePcg(const Block& rhs, Block* x, SolveSummary* summary) const;

  // kTwoGridMixedMinres: B, M and K_bulk - r from the mesh; adds the volumetric part that A_r
  // lacks to K_fp, which the constructor assembled for A_r.
  void AssembleVolumeChange(const HexMesh& mesh, double bulk_excess_mpa);
  // Y = [A_r B^T; B -M / (K_bulk - r)] X.
  void MultiplyMixed(const MixedBlock& x, MixedBlock* y) const;
  // The residual f - K u of the displacement form, K = A_r + (K_bulk - r) B^T M^-1 B.
  void DisplacementResidual(const Block& rhs, const Block& u, Block* residual) const;
  // Z = diag(two-grid cycle on A_r, M^-1 / pressure_preconditioner) R.
  void PreconditionMixed(const MixedBlock& r, MixedBlock* z, Block* work, Block* scratch) const;
  // Block MINRES on the mixed form (Elman, Silvester, Wathen, Finite Elements and Fast
  // Iterative Solvers, 2014, algorithm 4.1, one set of scalars a column); x holds the
  // displacements on return.
  void SolveMixedMinres(const Block& rhs, Block* x, SolveSummary* summary) const;
};

Eigen::SparseMatrix<double> ElasticSolver::Impl::Assemble(const HexMesh& mesh,
                                                          const ElasticMaterial& material,
                                                          const std::vector<bool>& fixed,
                                                          bool show_progress) {
  material.Validate();
  if (static_cast<int>(fixed.size()) != mesh.num_dofs()) {
    throw Error(fmt::format(
        "ElasticSolver: {} fixed-DOF flags for a mesh of {} DOFs", fixed.size(), mesh.num_dofs()));
  }
  const auto assembly_start = std::chrono::steady_clock::now();
  num_dofs = mesh.num_dofs();
  free_index.assign(num_dofs, -1);
  fixed_index.assign(num_dofs, -1);
  int num_free = 0;
  int num_fixed = 0;
  for (int d = 0; d < num_dofs; ++d) {
    if (fixed[d]) {
      fixed_index[d] = num_fixed++;
    } else {
      free_index[d] = num_free++;
    }
  }
  if (num_free == 0) throw Error("ElasticSolver: every DOF is fixed");
  summary.num_free_dofs = num_free;
  summary.num_fixed_dofs = num_fixed;

  // The pattern of the lower triangle of K_ff, column by column. Free indices grow with the
  // DOF index, so each column's rows come out sorted.
  const std::vector<std::vector<int>> neighbours = NodeNeighbours(mesh);
  Eigen::SparseMatrix<double> k(num_free, num_free);
  std::vector<int> outer(num_free + 1, 0);
  std::vector<int> inner;
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    for (int c = 0; c < 3; ++c) {
      const int col = free_index[3 * node + c];
      if (col < 0) continue;
      for (int other : neighbours[node]) {
        for (int d = 0; d < 3; ++d) {
          const int row = free_index[3 * other + d];
          if (row >= col) inner.push_back(row);
        }
      }
      outer[col + 1] = static_cast<int>(inner.size());
    }
  }
  k.resizeNonZeros(static_cast<Eigen::Index>(inner.size()));
  std::copy(outer.begin(), outer.end(), k.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), k.innerIndexPtr());
  std::fill_n(k.valuePtr(), inner.size(), 0.0);
  summary.stiffness_nonzeros = static_cast<long>(inner.size());
  std::vector<int>().swap(inner);

  ProgressBar assembly_bar("fem: assembly", mesh.num_elements(), show_progress);
  std::vector<Eigen::Triplet<double>> free_fixed;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const Hex8Matrix ke = CalcHex8Stiffness(mesh.ElementNodes(e), material);
    std::array<int, 24> dofs;
    for (int a = 0; a < 8; ++a) {
      for (int c = 0; c < 3; ++c) dofs[3 * a + c] = 3 * mesh.elements[e][a] + c;
    }
    for (int q = 0; q < 24; ++q) {
      const int col = free_index[dofs[q]];
      const int fixed_col = fixed_index[dofs[q]];
      for (int p = 0; p < 24; ++p) {
        const int row = free_index[dofs[p]];
        if (row < 0) continue;
        if (fixed_col >= 0) {
          free_fixed.emplace_back(row, fixed_col, ke(p, q));
        } else if (row >= col) {
          int* begin = k.innerIndexPtr() + outer[col];
          int* end = k.innerIndexPtr() + outer[col + 1];
          int* it = std::lower_bound(begin, end, row);
          TAC3D_DEMAND(it != end && *it == row);
          k.valuePtr()[it - k.innerIndexPtr()] += ke(p, q);
        }
      }
    }
    if (e % 1024 == 0) assembly_bar.Update(e);
  }
  assembly_bar.Finish();
  stiffness_free_fixed.resize(num_free, num_fixed);
  stiffness_free_fixed.setFromTriplets(free_fixed.begin(), free_fixed.end());

  std::vector<Eigen::Triplet<double>> selection_triplets;
  selection_triplets.reserve(num_free);
  for (int d = 0; d < num_dofs; ++d) {
    if (free_index[d] >= 0) selection_triplets.emplace_back(d, free_index[d], 1.0);
  }
  selection.resize(num_dofs, num_free);
  selection.setFromTriplets(selection_triplets.begin(), selection_triplets.end());
  summary.assembly_s = SecondsSince(assembly_start);
  return k;
}

void ElasticSolver::Impl::Factor(const Eigen::SparseMatrix<double>& k, bool show_progress) {
  const auto factor_start = std::chrono::steady_clock::now();
  ProgressBar factor_bar("fem: factorisation", 1, show_progress);
  // The ordering's vertices are the mesh nodes with a free DOF.
  std::vector<int> node_of(summary.num_free_dofs);
  int num_nodes = 0;
  for (int d = 0; d < num_dofs; ++d) {
    if (d % 3 == 0 && (free_index[d] >= 0 || free_index[d + 1] >= 0 || free_index[d + 2] >= 0)) {
      ++num_nodes;
    }
    if (free_index[d] >= 0) node_of[free_index[d]] = num_nodes - 1;
  }
  try {
    factor = std::make_unique<SparseCholesky>(k, node_of, "free-DOF stiffness matrix");
  } catch (const Error& e) {
    throw Error(fmt::format("ElasticSolver: {}", e.what()));
  }
  factor_bar.Finish();
  summary.factorization_s = SecondsSince(factor_start);
  summary.factor_nonzeros = factor->factor_nonzeros();
  summary.factor_flops = factor->factor_flops();
}

void ElasticSolver::Impl::AssembleVolumeChange(const HexMesh& mesh, double bulk_excess_mpa) {
  std::vector<Eigen::Triplet<double>> free_part;
  std::vector<Eigen::Triplet<double>> fixed_part;
  element_volume.resize(mesh.num_elements());
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const Hex8Vector row = CalcHex8VolumeChange(mesh.ElementNodes(e), &element_volume(e));
    for (int a = 0; a < 8; ++a) {
      for (int c = 0; c < 3; ++c) {
        const int dof = 3 * mesh.elements[e][a] + c;
        if (free_index[dof] >= 0) {
          free_part.emplace_back(e, free_index[dof], row(3 * a + c));
        } else {
          fixed_part.emplace_back(e, fixed_index[dof], row(3 * a + c));
        }
      }
    }
  }
  volume_change.resize(mesh.num_elements(), summary.num_free_dofs);
  volume_change.setFromTriplets(free_part.begin(), free_part.end());
  Eigen::SparseMatrix<double, Eigen::RowMajor> volume_change_fixed(mesh.num_elements(),
                                                                   summary.num_fixed_dofs);
  volume_change_fixed.setFromTriplets(fixed_part.begin(), fixed_part.end());
  bulk_excess = bulk_excess_mpa;
  const Eigen::VectorXd excess_over_volume = bulk_excess / element_volume.array();
  stiffness_free_fixed += Eigen::SparseMatrix<double>(
      volume_change.transpose() * excess_over_volume.asDiagonal() * volume_change_fixed);
  summary.num_pressures = mesh.num_elements();
}

void PcgOptions::Validate() const {
  if (!(relative_tolerance > 0.0 && relative_tolerance < 1.0)) {
    throw Error(
        fmt::format("PcgOptions.relative_tolerance must be in (0, 1), got {}", relative_tolerance));
  }
  if (!(mixed_bulk_split > 0.0)) {
    throw Error(fmt::format("PcgOptions.mixed_bulk_split must be > 0, got {}", mixed_bulk_split));
  }
  if (threads < 0) throw Error(fmt::format("PcgOptions.threads must be >= 0, got {}", threads));
  for (const auto& [value, field] : {std::pair{max_iterations, "max_iterations"},
                                     std::pair{smoothing_sweeps, "smoothing_sweeps"},
                                     std::pair{block_columns, "block_columns"}}) {
    if (value < 1) throw Error(fmt::format("PcgOptions.{} must be >= 1, got {}", field, value));
  }
}

ElasticSolver::ElasticSolver(const HexMesh& mesh,
                             const ElasticMaterial& material,
                             const std::vector<bool>& fixed,
                             bool show_progress)
    : impl_(std::make_unique<Impl>()) {
  impl_->Factor(impl_->Assemble(mesh, material, fixed, show_progress), show_progress);
}

ElasticSolver::ElasticSolver(const HexMesh& mesh,
                             const ElasticMaterial& material,
                             const std::vector<bool>& fixed,
                             const HexMesh& coarse_mesh,
                             const std::vector<bool>& coarse_fixed,
                             const Eigen::SparseMatrix<double>& prolongation,
                             const PcgOptions& options,
                             bool show_progress)
    : impl_(std::make_unique<Impl>()) {
  options.Validate();
  if (prolongation.rows() != mesh.num_dofs() || prolongation.cols() != coarse_mesh.num_dofs()) {
    throw Error(fmt::format(
        "ElasticSolver: the prolongation is {} x {}, the meshes have {} (fine) and {} (coarse) "
        "DOFs",
        prolongation.rows(),
        prolongation.cols(),
        mesh.num_dofs(),
        coarse_mesh.num_dofs()));
  }
  Impl& s = *impl_;
  s.pcg = options;
  if (s.pcg.threads == 0) {
    s.pcg.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  }
  material.Validate();
  const bool mixed = options.mixed_form;
  const double shear = material.shear_modulus();
  // r, at most half the bulk modulus so that the pressure block keeps K_bulk - r > 0.
  const double split_bulk =
      std::min(options.mixed_bulk_split * shear, 0.5 * material.bulk_modulus());
  // The mixed form's A_r: the same shear modulus, the bulk modulus r.
  const ElasticMaterial level_material = mixed ? WithBulkModulus(material, split_bulk) : material;
  s.stiffness_lower = s.Assemble(mesh, level_material, fixed, show_progress);
  if (mixed) {
    const auto start = std::chrono::steady_clock::now();
    s.AssembleVolumeChange(mesh, material.bulk_modulus() - split_bulk);
    s.pressure_preconditioner = 1.0 / (4.0 / 3.0 * shear + split_bulk) + 1.0 / s.bulk_excess;
    s.summary.assembly_s += SecondsSince(start);
  }
  // The smoother and the product read each column's diagonal as its first entry.
  for (int j = 0; j < s.summary.num_free_dofs; ++j) {
    TAC3D_DEMAND(s.stiffness_lower.innerIndexPtr()[s.stiffness_lower.outerIndexPtr()[j]] == j);
  }
  // The coarse mesh's own stiffness only sets up its DOF maps: the coarse operator is the
  // Galerkin P^T K P, which on the small test dome at nu 0.499 halved the iterations against the
  // rediscretised one (docs/fem.md).
  s.coarse = std::make_unique<Impl>();
  s.coarse->Assemble(coarse_mesh, level_material, coarse_fixed, show_progress);
  // Interpolation weights of a fine node on a coarse face at the far nodes of the element it
  // was located in are rounding, but they widen P^T K P's pattern: at refinement 2 of the
  // default dome its factor had 3.3e8 non-zeros with them, 1.2e8 without.
  constexpr double kNegligibleWeight = 1e-9;
  s.prolongation = s.selection.transpose() * prolongation * s.coarse->selection;
  s.prolongation.prune(1.0, kNegligibleWeight);
  const auto galerkin_start = std::chrono::steady_clock::now();
  const Eigen::SparseMatrix<double> coarse_stiffness =
      GalerkinLower(s.stiffness_lower, s.prolongation);
  s.coarse->summary.assembly_s += SecondsSince(galerkin_start);
  s.coarse->Factor(coarse_stiffness, show_progress);
  const ElasticSolverSummary& coarse_summary = s.coarse->summary;
  s.summary.method =
      mixed ? ElasticSolverMethod::kTwoGridMixedMinres : ElasticSolverMethod::kTwoGridPcg;
  s.summary.coarse_free_dofs = coarse_summary.num_free_dofs;
  s.summary.assembly_s += coarse_summary.assembly_s;
  s.summary.factorization_s = coarse_summary.factorization_s;
  s.summary.factor_nonzeros = coarse_summary.factor_nonzeros;
  s.summary.factor_flops = coarse_summary.factor_flops;
}

void ElasticSolver::Impl::Precondition(const Block& r,
                                       Block* z,
                                       Block* work,
                                       Block* scratch) const {
  z->setZero(r.rows(), r.cols());
  for (int sweep = 0; sweep < pcg.smoothing_sweeps; ++sweep) {
    GaussSeidelSweep(stiffness_lower, r, true, z, work);
  }
  MultiplySymmetric(stiffness_lower, *z, scratch);
  *scratch = r - *scratch;
  const Eigen::MatrixXd coarse_rhs = prolongation.transpose() * *scratch;
  const Eigen::MatrixXd coarse_correction = coarse->factor->Solve(coarse_rhs);
  z->noalias() += prolongation * coarse_correction;
  for (int sweep = 0; sweep < pcg.smoothing_sweeps; ++sweep) {
    GaussSeidelSweep(stiffness_lower, r, false, z, work);
  }
}

Error ElasticSolver::Impl::NotConverged(int c, int m, double residual, int iterations) const {
  return Error(fmt::format(
      "ElasticSolver: {} did not converge for load case {} of {}: relative residual {:.3g} after "
      "{} iterations (tolerance {:.3g}, limit {}; {} free DOFs, {} coarse)",
      summary.method == ElasticSolverMethod::kTwoGridMixedMinres
          ? "two-grid MINRES on the mixed form"
          : "two-grid conjugate gradients",
      c,
      m,
      residual,
      iterations,
      pcg.relative_tolerance,
      pcg.max_iterations,
      summary.num_free_dofs,
      summary.coarse_free_dofs));
}

void ElasticSolver::Impl::SolvePcg(const Block& rhs, Block* x, SolveSummary* out) const {
  const int m = static_cast<int>(rhs.cols());
  const double tolerance = pcg.relative_tolerance;
  const Eigen::VectorXd rhs_norm = ColumnDots(rhs, rhs).cwiseSqrt();
  Eigen::VectorXi iterations = Eigen::VectorXi::Zero(m);
  Eigen::VectorXd residual(m);
  Block r, z, p, q, work;
  x->setZero(rhs.rows(), m);
  const auto not_converged = [&](int c) { return NotConverged(c, m, residual(c), iterations(c)); };
  // Restarted from the true residual until it, not only the recurrence's, meets the tolerance.
  while (true) {
    if (iterations.maxCoeff() == 0) {
      r = rhs;
    } else {
      MultiplySymmetric(stiffness_lower, *x, &q);
      r = rhs - q;
    }
    const Eigen::VectorXd r_norm = ColumnDots(r, r).cwiseSqrt();
    Eigen::Array<bool, Eigen::Dynamic, 1> active(m);
    for (int c = 0; c < m; ++c) {
      residual(c) = rhs_norm(c) > 0.0 ? r_norm(c) / rhs_norm(c) : 0.0;
      active(c) = residual(c) > tolerance;
      if (active(c) && iterations(c) >= pcg.max_iterations) throw not_converged(c);
    }
    if (!active.any()) break;
    Precondition(r, &z, &work, &q);
    p = z;
    Eigen::VectorXd rz = ColumnDots(r, z);
    while (true) {
      MultiplySymmetric(stiffness_lower, p, &q);
      const Eigen::VectorXd pq = ColumnDots(p, q);
      Eigen::VectorXd alpha = Eigen::VectorXd::Zero(m);
      for (int c = 0; c < m; ++c) {
        if (active(c)) alpha(c) = rz(c) / pq(c);
      }
      x->noalias() += p * alpha.asDiagonal();
      r.noalias() -= q * alpha.asDiagonal();
      const Eigen::VectorXd r_norm_now = ColumnDots(r, r).cwiseSqrt();
      for (int c = 0; c < m; ++c) {
        if (!active(c)) continue;
        ++iterations(c);
        residual(c) = r_norm_now(c) / rhs_norm(c);
        if (!(residual(c) > tolerance)) {
          active(c) = false;
        } else if (iterations(c) >= pcg.max_iterations) {
          throw not_converged(c);
        }
      }
      if (!active.any()) break;
      Precondition(r, &z, &work, &q);
      const Eigen::VectorXd rz_next = ColumnDots(r, z);
      Eigen::VectorXd beta = Eigen::VectorXd::Zero(m);
      for (int c = 0; c < m; ++c) {
        if (active(c)) beta(c) = rz_next(c) / rz(c);
      }
      p = z + p * beta.asDiagonal();
      rz = rz_next;
    }
  }
  if (out != nullptr) {
    out->iterations.insert(out->iterations.end(), iterations.begin(), iterations.end());
    out->relative_residuals.insert(out->relative_residuals.end(), residual.begin(), residual.end());
  }
}

void ElasticSolver::Impl::MultiplyMixed(const MixedBlock& x, MixedBlock* y) const {
  MultiplySymmetric(stiffness_lower, x.u, &y->u);
  y->u.noalias() += volume_change.transpose() * x.p;
  y->p.noalias() = volume_change * x.u;
  y->p.noalias() -= (element_volume / bulk_excess).asDiagonal() * x.p;
}

void ElasticSolver::Impl::DisplacementResidual(const Block& rhs,
                                               const Block& u,
                                               Block* residual) const {
  MultiplySymmetric(stiffness_lower, u, residual);
  const Block pressure =
      (bulk_excess / element_volume.array()).matrix().asDiagonal() * (volume_change * u);
  *residual = rhs - *residual;
  residual->noalias() -= volume_change.transpose() * pressure;
}

void ElasticSolver::Impl::PreconditionMixed(const MixedBlock& r,
                                            MixedBlock* z,
                                            Block* work,
                                            Block* scratch) const {
  Precondition(r.u, &z->u, work, scratch);
  z->p = (1.0 / (pressure_preconditioner * element_volume.array())).matrix().asDiagonal() * r.p;
}

void ElasticSolver::Impl::SolveMixedMinres(const Block& rhs, Block* x, SolveSummary* out) const {
  const int n = static_cast<int>(rhs.rows()), m = static_cast<int>(rhs.cols());
  const int num_pressures = static_cast<int>(element_volume.size());
  const Eigen::VectorXd rhs_norm = ColumnDots(rhs, rhs).cwiseSqrt();
  Eigen::VectorXi iterations = Eigen::VectorXi::Zero(m);
  Eigen::VectorXd residual = Eigen::VectorXd::Zero(m);
  Eigen::Array<bool, Eigen::Dynamic, 1> active =
      Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(m, true);
  // Every iteration, on the residual of K u = f itself: the norm MINRES minimises weighs the
  // pressure equation's residual, which elimination multiplies by K_bulk - r. u is all the
  // caller needs, so the pressures' iterate is not kept.
  const auto check = [&](Block* r) {
    DisplacementResidual(rhs, *x, r);
    const Eigen::VectorXd r_norm = ColumnDots(*r, *r).cwiseSqrt();
    for (int c = 0; c < m; ++c) {
      if (!active(c)) continue;
      residual(c) = rhs_norm(c) > 0.0 ? r_norm(c) / rhs_norm(c) : 0.0;
      if (!(residual(c) > pcg.relative_tolerance)) {
        active(c) = false;
      } else if (iterations(c) >= pcg.max_iterations) {
        throw NotConverged(c, m, residual(c), iterations(c));
      }
    }
  };
  const auto zero = [&] { return MixedBlock{Block::Zero(n, m), Block::Zero(num_pressures, m)}; };
  x->setZero(n, m);
  MixedBlock v = zero(), v_previous = zero(), w = zero(), w_previous = zero(), z, z_next, product;
  Block work;
  check(&v.u);
  // The Lanczos scalars of each column; a finished column's are zero, so its vectors vanish.
  Eigen::VectorXd gamma_previous = Eigen::VectorXd::Ones(m), gamma(m), gamma_next(m);
  Eigen::VectorXd cosine_previous = Eigen::VectorXd::Ones(m), cosine = Eigen::VectorXd::Ones(m);
  Eigen::VectorXd sine_previous = Eigen::VectorXd::Zero(m), sine = Eigen::VectorXd::Zero(m);
  const auto if_active = [&](const Eigen::VectorXd& values) {
    return Eigen::VectorXd(active.select(values.array(), 0.0));
  };
  ScaleColumns(if_active(Eigen::VectorXd::Ones(m)), &v);
  PreconditionMixed(v, &z, &work, &product.u);
  gamma = ColumnDots(z, v).cwiseMax(0.0).cwiseSqrt();
  Eigen::VectorXd eta = gamma;
  while (active.any()) {
    const Eigen::VectorXd inverse_gamma =
        if_active((gamma.array() > 0.0).select(gamma.array().inverse(), 0.0).matrix());
    ScaleColumns(inverse_gamma, &z);
    MultiplyMixed(z, &product);
    const Eigen::VectorXd delta = ColumnDots(product, z);
    // The next Lanczos vector, in v_previous's storage.
    ScaleColumns(-if_active(gamma.cwiseQuotient(gamma_previous)), &v_previous);
    AddScaled(v, -delta.cwiseProduct(inverse_gamma), &v_previous);
    AddScaled(product, Eigen::VectorXd::Ones(m), &v_previous);
    std::swap(v, v_previous);
    PreconditionMixed(v, &z_next, &work, &product.u);
    gamma_next = if_active(ColumnDots(z_next, v).cwiseMax(0.0).cwiseSqrt());
    // The Givens rotation of each column, and the next search direction's coefficients.
    Eigen::VectorXd z_factor = Eigen::VectorXd::Zero(m), w_factor = Eigen::VectorXd::Zero(m),
                    w_previous_factor = Eigen::VectorXd::Zero(m), step = Eigen::VectorXd::Zero(m);
    for (int c = 0; c < m; ++c) {
      if (!active(c)) continue;
      const double a0 = cosine(c) * delta(c) - cosine_previous(c) * sine(c) * gamma(c);
      const double a1 = std::hypot(a0, gamma_next(c));
      const double a2 = sine(c) * delta(c) + cosine_previous(c) * cosine(c) * gamma(c);
      const double a3 = sine_previous(c) * gamma(c);
      ++iterations(c);
      if (!(a1 > 0.0)) continue;  // the Krylov space holds the solution: nothing to add
      z_factor(c) = 1.0 / a1;
      w_factor(c) = -a2 / a1;
      w_previous_factor(c) = -a3 / a1;
      cosine_previous(c) = cosine(c);
      sine_previous(c) = sine(c);
      cosine(c) = a0 / a1;
      sine(c) = gamma_next(c) / a1;
      step(c) = cosine(c) * eta(c);
      eta(c) *= -sine(c);
    }
    ScaleColumns(w_previous_factor, &w_previous);
    AddScaled(w, w_factor, &w_previous);
    AddScaled(z, z_factor, &w_previous);
    std::swap(w, w_previous);
    x->noalias() += w.u * step.asDiagonal();
    check(&product.u);
    std::swap(z, z_next);
    gamma_previous = gamma;
    gamma = gamma_next;
  }
  if (out != nullptr) {
    out->iterations.insert(out->iterations.end(), iterations.begin(), iterations.end());
    out->relative_residuals.insert(out->relative_residuals.end(), residual.begin(), residual.end());
  }
}

Eigen::MatrixXd ElasticSolver::Impl::SolveFree(const Eigen::MatrixXd& rhs,
                                               SolveSummary* out) const {
  if (summary.method == ElasticSolverMethod::kDirect) return factor->Solve(rhs);
  const auto start = std::chrono::steady_clock::now();
  // The load cases split into one block a thread, each iterated on its own: each thread
  // streams K, and only the coarse factor's solves take turns.
  const int m = static_cast<int>(rhs.cols());
  const int parts = std::max(1, std::min(pcg.threads, m));
  std::vector<Block> x(parts);
  std::vector<SolveSummary> part_summaries(parts);
  std::vector<std::exception_ptr> errors(parts);
  const auto solve_part = [&](int t) {
    try {
      const int begin = m * t / parts, end = m * (t + 1) / parts;
      const Block part_rhs = rhs.middleCols(begin, end - begin);
      if (summary.method == ElasticSolverMethod::kTwoGridMixedMinres) {
        SolveMixedMinres(part_rhs, &x[t], &part_summaries[t]);
      } else {
        SolvePcg(part_rhs, &x[t], &part_summaries[t]);
      }
    } catch (...) {
      errors[t] = std::current_exception();
    }
  };
  std::vector<std::thread> workers;
  for (int t = 1; t < parts; ++t) workers.emplace_back(solve_part, t);
  solve_part(0);
  for (std::thread& worker : workers) worker.join();
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
  Eigen::MatrixXd solution(rhs.rows(), m);
  for (int t = 0; t < parts; ++t) {
    const int begin = m * t / parts;
    solution.middleCols(begin, x[t].cols()) = x[t];
    if (out != nullptr) {
      const SolveSummary& part = part_summaries[t];
      out->iterations.insert(out->iterations.end(), part.iterations.begin(), part.iterations.end());
      out->relative_residuals.insert(out->relative_residuals.end(),
                                     part.relative_residuals.begin(),
                                     part.relative_residuals.end());
    }
  }
  if (out != nullptr) out->solve_s += SecondsSince(start);
  return solution;
}

ElasticSolver::~ElasticSolver() = default;
ElasticSolver::ElasticSolver(ElasticSolver&&) noexcept = default;
ElasticSolver& ElasticSolver::operator=(ElasticSolver&&) noexcept = default;

int ElasticSolver::num_dofs() const { return impl_->num_dofs; }

const ElasticSolverSummary& ElasticSolver::summary() const { return impl_->summary; }

Eigen::VectorXd ElasticSolver::Solve(const Eigen::VectorXd& nodal_forces,
                                     const Eigen::VectorXd& prescribed,
                                     SolveSummary* summary) const {
  const Impl& s = *impl_;
  TAC3D_DEMAND(nodal_forces.size() == s.num_dofs);
  TAC3D_DEMAND(prescribed.size() == 0 || prescribed.size() == s.num_dofs);
  Eigen::VectorXd prescribed_fixed = Eigen::VectorXd::Zero(s.summary.num_fixed_dofs);
  if (prescribed.size() > 0) {
    for (int d = 0; d < s.num_dofs; ++d) {
      if (s.fixed_index[d] >= 0) prescribed_fixed(s.fixed_index[d]) = prescribed(d);
    }
  }
  const Eigen::VectorXd rhs =
      s.selection.transpose() * nodal_forces - s.stiffness_free_fixed * prescribed_fixed;
  const Eigen::VectorXd free_u = s.SolveFree(rhs, summary);
  Eigen::VectorXd u = s.selection * free_u;
  for (int d = 0; d < s.num_dofs; ++d) {
    if (s.fixed_index[d] >= 0) u(d) = prescribed_fixed(s.fixed_index[d]);
  }
  return u;
}

Eigen::MatrixXd ElasticSolver::CalcResponse(const Eigen::SparseMatrix<double>& readout,
                                            const Eigen::SparseMatrix<double>& nodal_forces,
                                            bool show_progress,
                                            int chunk_columns,
                                            SolveSummary* summary) const {
  const Impl& s = *impl_;
  TAC3D_DEMAND(readout.cols() == s.num_dofs && nodal_forces.rows() == s.num_dofs);
  TAC3D_DEMAND(chunk_columns >= 1);
  const Eigen::SparseMatrix<double> readout_free = readout * s.selection;
  const Eigen::SparseMatrix<double> forces_free = s.selection.transpose() * nodal_forces;
  const int cases = static_cast<int>(nodal_forces.cols());
  if (s.summary.method == ElasticSolverMethod::kDirect) {
    ProgressBar bar("fem: solves (%)", 100, show_progress);
    Eigen::MatrixXd response =
        s.factor->CalcBilinear(readout_free.transpose(),
                               forces_free,
                               SparseCholesky::Method::kCheapest,
                               chunk_columns,
                               [&](double done) { bar.Update(std::lround(100.0 * done)); });
    bar.Finish();
    return response;
  }
  if (cases > 0) {
    // Equal chunks: a short last block would cost a full pass over K per iteration.
    const int chunks = (cases + s.pcg.block_columns - 1) / s.pcg.block_columns;
    chunk_columns = std::min(chunk_columns, (cases + chunks - 1) / chunks);
  }
  Eigen::MatrixXd response(readout.rows(), cases);
  ProgressBar bar("fem: solves", cases, show_progress);
  for (int begin = 0; begin < cases; begin += chunk_columns) {
    const int count = std::min(chunk_columns, cases - begin);
    const Eigen::MatrixXd rhs = forces_free.middleCols(begin, count);
    const Eigen::MatrixXd u = s.SolveFree(rhs, summary);
    response.middleCols(begin, count) = readout_free * u;
    bar.Update(begin + count);
  }
  bar.Finish();
  return response;
}

}  // namespace tac3d::fem
