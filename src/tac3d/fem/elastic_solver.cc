#include "tac3d/fem/elastic_solver.h"

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <chrono>

#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"

namespace tac3d::fem {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

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

}  // namespace

struct ElasticSolver::Impl {
  int num_dofs = 0;
  std::vector<int> free_index;                       // DOF -> free-DOF index, or -1
  std::vector<int> fixed_index;                      // DOF -> fixed-DOF index, or -1
  Eigen::SparseMatrix<double> selection;             // num_dofs x free: embeds free DOFs
  Eigen::SparseMatrix<double> stiffness_free_fixed;  // K_fp
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt;
  ElasticSolverSummary summary;
};

ElasticSolver::ElasticSolver(const HexMesh& mesh,
                             const ElasticMaterial& material,
                             const std::vector<bool>& fixed,
                             bool show_progress)
    : impl_(std::make_unique<Impl>()) {
  material.Validate();
  if (static_cast<int>(fixed.size()) != mesh.num_dofs()) {
    throw Error(fmt::format(
        "ElasticSolver: {} fixed-DOF flags for a mesh of {} DOFs", fixed.size(), mesh.num_dofs()));
  }
  const auto assembly_start = std::chrono::steady_clock::now();
  Impl& s = *impl_;
  s.num_dofs = mesh.num_dofs();
  s.free_index.assign(s.num_dofs, -1);
  s.fixed_index.assign(s.num_dofs, -1);
  int num_free = 0;
  int num_fixed = 0;
  for (int d = 0; d < s.num_dofs; ++d) {
    if (fixed[d]) {
      s.fixed_index[d] = num_fixed++;
    } else {
      s.free_index[d] = num_free++;
    }
  }
  if (num_free == 0) throw Error("ElasticSolver: every DOF is fixed");
  s.summary.num_free_dofs = num_free;
  s.summary.num_fixed_dofs = num_fixed;

  // The pattern of the lower triangle of K_ff, column by column. Free indices grow with the
  // DOF index, so each column's rows come out sorted.
  const std::vector<std::vector<int>> neighbours = NodeNeighbours(mesh);
  Eigen::SparseMatrix<double> k(num_free, num_free);
  std::vector<int> outer(num_free + 1, 0);
  std::vector<int> inner;
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    for (int c = 0; c < 3; ++c) {
      const int col = s.free_index[3 * node + c];
      if (col < 0) continue;
      for (int other : neighbours[node]) {
        for (int d = 0; d < 3; ++d) {
          const int row = s.free_index[3 * other + d];
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
  s.summary.stiffness_nonzeros = static_cast<long>(inner.size());
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
      const int col = s.free_index[dofs[q]];
      const int fixed_col = s.fixed_index[dofs[q]];
      for (int p = 0; p < 24; ++p) {
        const int row = s.free_index[dofs[p]];
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
  s.stiffness_free_fixed.resize(num_free, num_fixed);
  s.stiffness_free_fixed.setFromTriplets(free_fixed.begin(), free_fixed.end());

  std::vector<Eigen::Triplet<double>> selection;
  selection.reserve(num_free);
  for (int d = 0; d < s.num_dofs; ++d) {
    if (s.free_index[d] >= 0) selection.emplace_back(d, s.free_index[d], 1.0);
  }
  s.selection.resize(s.num_dofs, num_free);
  s.selection.setFromTriplets(selection.begin(), selection.end());
  s.summary.assembly_s = SecondsSince(assembly_start);

  const auto factor_start = std::chrono::steady_clock::now();
  ProgressBar factor_bar("fem: factorisation", 1, show_progress);
  s.llt.compute(k);
  factor_bar.Finish();
  if (s.llt.info() != Eigen::Success) {
    throw Error(
        "ElasticSolver: the stiffness matrix is not positive definite; the fixed DOFs leave a "
        "rigid-body motion free");
  }
  s.summary.factorization_s = SecondsSince(factor_start);
  s.summary.factor_nonzeros = s.llt.cholmod().lnz;
  s.summary.factor_flops = s.llt.cholmod().fl;
}

ElasticSolver::~ElasticSolver() = default;
ElasticSolver::ElasticSolver(ElasticSolver&&) noexcept = default;
ElasticSolver& ElasticSolver::operator=(ElasticSolver&&) noexcept = default;

int ElasticSolver::num_dofs() const { return impl_->num_dofs; }

const ElasticSolverSummary& ElasticSolver::summary() const { return impl_->summary; }

Eigen::VectorXd ElasticSolver::Solve(const Eigen::VectorXd& nodal_forces,
                                     const Eigen::VectorXd& prescribed) const {
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
  const Eigen::VectorXd free_u = s.llt.solve(rhs);
  Eigen::VectorXd u = s.selection * free_u;
  for (int d = 0; d < s.num_dofs; ++d) {
    if (s.fixed_index[d] >= 0) u(d) = prescribed_fixed(s.fixed_index[d]);
  }
  return u;
}

Eigen::MatrixXd ElasticSolver::CalcResponse(const Eigen::SparseMatrix<double>& readout,
                                            const Eigen::SparseMatrix<double>& nodal_forces,
                                            bool show_progress,
                                            int chunk_columns) const {
  const Impl& s = *impl_;
  TAC3D_DEMAND(readout.cols() == s.num_dofs && nodal_forces.rows() == s.num_dofs);
  TAC3D_DEMAND(chunk_columns >= 1);
  const Eigen::SparseMatrix<double> readout_free = readout * s.selection;
  const Eigen::SparseMatrix<double> forces_free = s.selection.transpose() * nodal_forces;
  const int cases = static_cast<int>(nodal_forces.cols());
  Eigen::MatrixXd response(readout.rows(), cases);
  ProgressBar bar("fem: solves", cases, show_progress);
  for (int begin = 0; begin < cases; begin += chunk_columns) {
    const int count = std::min(chunk_columns, cases - begin);
    const Eigen::MatrixXd rhs = forces_free.middleCols(begin, count);
    const Eigen::MatrixXd u = s.llt.solve(rhs);
    response.middleCols(begin, count) = readout_free * u;
    bar.Update(begin + count);
  }
  bar.Finish();
  return response;
}

}  // namespace tac3d::fem
