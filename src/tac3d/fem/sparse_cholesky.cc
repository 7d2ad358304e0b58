#include "tac3d/fem/sparse_cholesky.h"

#include <cholmod.h>

#include <algorithm>
#include <mutex>
#include <numeric>

#include "tac3d/util/error.h"

// BLAS (OpenBLAS provides it; CHOLMOD's supernodal kernels use the same).
extern "C" void dtrsm_(const char* side,
                       const char* uplo,
                       const char* transa,
                       const char* diag,
                       const int* m,
                       const int* n,
                       const double* alpha,
                       const double* a,
                       const int* lda,
                       double* b,
                       const int* ldb);
extern "C" void dgemm_(const char* transa,
                       const char* transb,
                       const int* m,
                       const int* n,
                       const int* k,
                       const double* alpha,
                       const double* a,
                       const int* lda,
                       const double* b,
                       const int* ldb,
                       const double* beta,
                       double* c,
                       const int* ldc);

namespace tac3d::fem {
namespace {

const char* CholmodStatusText(int status) {
  switch (status) {
    case CHOLMOD_NOT_INSTALLED:
      return "method not installed";
    case CHOLMOD_OUT_OF_MEMORY:
      return "out of memory";
    case CHOLMOD_TOO_LARGE:
      return "problem too large (an integer overflows CHOLMOD's indices)";
    case CHOLMOD_INVALID:
      return "invalid input";
    case CHOLMOD_GPU_PROBLEM:
      return "GPU problem";
    case CHOLMOD_NOT_POSDEF:
      return "not positive definite";
    case CHOLMOD_DSMALL:
      return "tiny pivot";
    default:
      return "unknown status";
  }
}

// A view of K's lower triangle as a CHOLMOD matrix (CHOLMOD does not write to it).
cholmod_sparse ViewLower(const Eigen::SparseMatrix<double>& lower) {
  cholmod_sparse a{};
  a.nrow = a.ncol = static_cast<size_t>(lower.rows());
  a.nzmax = static_cast<size_t>(lower.nonZeros());
  a.p = const_cast<int*>(lower.outerIndexPtr());
  a.i = const_cast<int*>(lower.innerIndexPtr());
  a.x = const_cast<double*>(lower.valuePtr());
  a.stype = -1;
  a.itype = CHOLMOD_INT;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
  return a;
}

// The lower triangle's pattern (no diagonal) of the graph whose vertices are the nodes, two
// nodes adjacent where K couples any of their unknowns; compressed columns.
struct NodeGraph {
  std::vector<int> outer;
  std::vector<int> inner;
};

NodeGraph BuildNodeGraph(const Eigen::SparseMatrix<double>& lower,
                         const std::vector<int>& node_of,
                         int num_nodes) {
  std::vector<std::vector<int>> larger(num_nodes);
  for (int col = 0; col < lower.cols(); ++col) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(lower, col); it; ++it) {
      const int a = node_of[col], b = node_of[it.row()];
      if (a != b) larger[std::min(a, b)].push_back(std::max(a, b));
    }
  }
  NodeGraph graph;
  graph.outer.assign(1, 0);
  for (std::vector<int>& neighbours : larger) {
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    graph.inner.insert(graph.inner.end(), neighbours.begin(), neighbours.end());
    graph.outer.push_back(static_cast<int>(graph.inner.size()));
    std::vector<int>().swap(neighbours);
  }
  return graph;
}

// Some columns of a sparse matrix X and the supernodes their forward solve L^-1 P X reaches
// (ascending); once solved, y holds the solution on the reach's rows, supernode after
// supernode (offsets[t] = the first row of supernodes[t], offsets.back() = y's rows).
struct ColumnBlock {
  std::vector<int> columns;
  std::vector<int> supernodes;
  std::vector<int> offsets;
  Eigen::MatrixXd y;
};

}  // namespace

struct SparseCholesky::Impl {
  mutable cholmod_common common;
  cholmod_factor* factor = nullptr;
  mutable std::mutex solve_mutex;
  int n = 0;
  // The supernodal elimination tree: each (permuted) column's supernode, each supernode's
  // parent (-1 at a root), and each original unknown's permuted index.
  std::vector<int> column_supernode;
  std::vector<int> parent;
  std::vector<int> permuted;

  Impl() { cholmod_start(&common); }
  ~Impl() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }

  // CHOLMOD's supernodal L: supernode k holds columns super[k] .. super[k + 1] - 1, its rows
  // are row_index[pi[k] ..  pi[k + 1] - 1] (its own columns first), its values a column-major
  // block from value[px[k]].
  const int* super() const { return static_cast<const int*>(factor->super); }
  const int* pi() const { return static_cast<const int*>(factor->pi); }
  const int* px() const { return static_cast<const int*>(factor->px); }
  const int* row_index() const { return static_cast<const int*>(factor->s); }
  const double* value() const { return static_cast<const double*>(factor->x); }

  // The columns of x in blocks of at most block_columns, columns whose first non-zero (in L's
  // order) is close together (they share most of their reach), with their reaches.
  std::vector<ColumnBlock> MakeBlocks(const Eigen::SparseMatrix<double>& x,
                                      int block_columns) const;
  // The supernodes reached from the rows of the listed columns of x, ascending.
  std::vector<int> Reach(const Eigen::SparseMatrix<double>& x,
                         const std::vector<int>& columns) const;
  // Flops of a triangular solve with one column on the supernodes (either direction).
  double SolveFlops(const std::vector<int>& supernodes) const;
  // The supernodes' row offsets in a block laid out as ColumnBlock::y.
  std::vector<int> Offsets(const std::vector<int>& supernodes) const;
  // block->y = L^-1 P x on the block's reach.
  void ForwardSolve(const Eigen::SparseMatrix<double>& x, ColumnBlock* block) const;
  // Solves L^T z = z in place on `supernodes` (closed under parents), z laid out by `offsets`.
  void BackwardSolve(const std::vector<int>& supernodes,
                     const std::vector<int>& offsets,
                     Eigen::MatrixXd* z) const;
  // Writes supernodes' first rows into `position` (size nsuper), -1 elsewhere.
  void Place(const std::vector<int>& supernodes,
             const std::vector<int>& offsets,
             std::vector<int>* position) const;
};

SparseCholesky::SparseCholesky(const Eigen::SparseMatrix<double>& lower,
                               const std::vector<int>& node_of,
                               const std::string& name)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  TAC3D_DEMAND(lower.rows() == lower.cols() &&
               static_cast<Eigen::Index>(node_of.size()) == lower.rows());
  s.n = static_cast<int>(lower.rows());
  cholmod_common& c = s.common;
  const auto fail = [&](const char* stage, const char* reason) {
    return Error(fmt::format(
        "CHOLMOD's {} of the {} x {} {} ({} non-zeros in its lower triangle) failed: {}",
        stage,
        lower.rows(),
        lower.cols(),
        name,
        lower.nonZeros(),
        reason));
  };
  c.supernodal = CHOLMOD_SUPERNODAL;
  c.final_asis = 1;
  cholmod_sparse a = ViewLower(lower);

  const int num_nodes = node_of.empty() ? 0 : *std::max_element(node_of.begin(), node_of.end()) + 1;
  std::vector<int> node_order(num_nodes);
  std::iota(node_order.begin(), node_order.end(), 0);
  if (num_nodes > 1) {
    NodeGraph graph = BuildNodeGraph(lower, node_of, num_nodes);
    cholmod_sparse g{};
    g.nrow = g.ncol = static_cast<size_t>(num_nodes);
    g.nzmax = graph.inner.size();
    g.p = graph.outer.data();
    g.i = graph.inner.data();
    g.stype = -1;
    g.itype = CHOLMOD_INT;
    g.xtype = CHOLMOD_PATTERN;
    g.dtype = CHOLMOD_DOUBLE;
    g.sorted = 1;
    g.packed = 1;
    if (!cholmod_metis(&g, nullptr, 0, /*postorder=*/0, node_order.data(), &c)) {
      throw fail("analysis", CholmodStatusText(c.status));
    }
  }
  // The unknowns node by node, in the nodes' order.
  std::vector<int> member_start(num_nodes + 1, 0);
  for (int node : node_of) ++member_start[node + 1];
  std::partial_sum(member_start.begin(), member_start.end(), member_start.begin());
  std::vector<int> place(member_start.begin(), member_start.end() - 1);
  std::vector<int> by_node(s.n);
  for (int i = 0; i < s.n; ++i) by_node[place[node_of[i]]++] = i;
  std::vector<int> perm;
  perm.reserve(s.n);
  for (int node : node_order) {
    perm.insert(
        perm.end(), by_node.begin() + member_start[node], by_node.begin() + member_start[node + 1]);
  }

  c.nmethods = 1;
  c.method[0].ordering = CHOLMOD_GIVEN;
  c.postorder = 1;
  s.factor = cholmod_analyze_p(&a, perm.data(), nullptr, 0, &c);
  if (s.factor == nullptr || c.status < CHOLMOD_OK) {
    throw fail("analysis", CholmodStatusText(c.status));
  }
  cholmod_factorize(&a, s.factor, &c);
  if (c.status != CHOLMOD_OK || s.factor->minor < s.factor->n) {
    throw fail("factorisation",
               c.status == CHOLMOD_NOT_POSDEF || c.status == CHOLMOD_OK
                   ? "not positive definite (singular or indefinite)"
                   : CholmodStatusText(c.status));
  }
  TAC3D_DEMAND(s.factor->is_super && s.factor->is_ll && s.factor->xtype == CHOLMOD_REAL);

  const int nsuper = static_cast<int>(s.factor->nsuper);
  const int* super = s.super();
  s.column_supernode.resize(s.n);
  for (int k = 0; k < nsuper; ++k) {
    std::fill(s.column_supernode.begin() + super[k], s.column_supernode.begin() + super[k + 1], k);
  }
  s.parent.assign(nsuper, -1);
  for (int k = 0; k < nsuper; ++k) {
    const int ncol = super[k + 1] - super[k];
    const int nrow = s.pi()[k + 1] - s.pi()[k];
    if (nrow > ncol) s.parent[k] = s.column_supernode[s.row_index()[s.pi()[k] + ncol]];
  }
  const int* factor_perm = static_cast<const int*>(s.factor->Perm);
  s.permuted.resize(s.n);
  for (int k = 0; k < s.n; ++k) s.permuted[factor_perm[k]] = k;
}

SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

int SparseCholesky::size() const { return impl_->n; }
double SparseCholesky::factor_nonzeros() const { return impl_->common.lnz; }
double SparseCholesky::factor_flops() const { return impl_->common.fl; }

Eigen::MatrixXd SparseCholesky::Solve(const Eigen::MatrixXd& rhs) const {
  const Impl& s = *impl_;
  TAC3D_DEMAND(rhs.rows() == s.n);
  cholmod_dense b{};
  b.nrow = static_cast<size_t>(rhs.rows());
  b.ncol = static_cast<size_t>(rhs.cols());
  b.nzmax = b.d = b.nrow;
  b.nzmax *= b.ncol;
  b.x = const_cast<double*>(rhs.data());
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  const std::lock_guard<std::mutex> lock(s.solve_mutex);
  cholmod_dense* x = cholmod_solve(CHOLMOD_A, s.factor, &b, &s.common);
  if (x == nullptr) {
    throw Error(fmt::format("CHOLMOD's solve failed: {}", CholmodStatusText(s.common.status)));
  }
  Eigen::MatrixXd result =
      Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), rhs.rows(), rhs.cols());
  cholmod_free_dense(&x, &s.common);
  return result;
}

std::vector<int> SparseCholesky::Impl::Reach(const Eigen::SparseMatrix<double>& x,
                                             const std::vector<int>& columns) const {
  std::vector<char> reached(parent.size(), 0);
  std::vector<int> reach;
  // From each non-zero's supernode up the tree to the first supernode already reached.
  for (int col : columns) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(x, col); it; ++it) {
      for (int k = column_supernode[permuted[it.row()]]; k >= 0 && !reached[k]; k = parent[k]) {
        reached[k] = 1;
        reach.push_back(k);
      }
    }
  }
  std::sort(reach.begin(), reach.end());
  return reach;
}

std::vector<int> SparseCholesky::Impl::Offsets(const std::vector<int>& supernodes) const {
  std::vector<int> offsets(supernodes.size() + 1, 0);
  for (size_t t = 0; t < supernodes.size(); ++t) {
    offsets[t + 1] = offsets[t] + super()[supernodes[t] + 1] - super()[supernodes[t]];
  }
  return offsets;
}

double SparseCholesky::Impl::SolveFlops(const std::vector<int>& supernodes) const {
  double flops = 0.0;
  for (int k : supernodes) {
    const double ncol = super()[k + 1] - super()[k];
    const double nrow = pi()[k + 1] - pi()[k];
    flops += ncol * ncol + 2.0 * (nrow - ncol) * ncol;
  }
  return flops;
}

std::vector<ColumnBlock> SparseCholesky::Impl::MakeBlocks(const Eigen::SparseMatrix<double>& x,
                                                          int block_columns) const {
  std::vector<std::pair<int, int>> first;  // (first permuted row, column); empty columns left out
  for (int j = 0; j < x.cols(); ++j) {
    int lowest = n;
    for (Eigen::SparseMatrix<double>::InnerIterator it(x, j); it; ++it) {
      lowest = std::min(lowest, permuted[it.row()]);
    }
    if (lowest < n) first.emplace_back(lowest, j);
  }
  std::sort(first.begin(), first.end());
  std::vector<ColumnBlock> blocks;
  for (size_t begin = 0; begin < first.size(); begin += block_columns) {
    ColumnBlock& block = blocks.emplace_back();
    for (size_t t = begin; t < std::min(first.size(), begin + block_columns); ++t) {
      block.columns.push_back(first[t].second);
    }
    block.supernodes = Reach(x, block.columns);
    block.offsets = Offsets(block.supernodes);
  }
  return blocks;
}

void SparseCholesky::Impl::Place(const std::vector<int>& supernodes,
                                 const std::vector<int>& offsets,
                                 std::vector<int>* position) const {
  position->assign(parent.size(), -1);
  for (size_t t = 0; t < supernodes.size(); ++t) (*position)[supernodes[t]] = offsets[t];
}

void SparseCholesky::Impl::ForwardSolve(const Eigen::SparseMatrix<double>& x,
                                        ColumnBlock* block) const {
  std::vector<int> position;
  Place(block->supernodes, block->offsets, &position);
  const auto local_row = [&](int k) {
    const int t = column_supernode[k];
    return position[t] + k - super()[t];
  };
  const int rows = block->offsets.back();
  const int cols = static_cast<int>(block->columns.size());
  Eigen::MatrixXd& y = block->y;
  y.setZero(rows, cols);
  for (int j = 0; j < cols; ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(x, block->columns[j]); it; ++it) {
      y(local_row(permuted[it.row()]), j) += it.value();
    }
  }
  // Children before parents: solve with the diagonal block, then subtract the off-diagonal
  // block's product from the ancestors' rows.
  const double one = 1.0, zero = 0.0;
  std::vector<double> work;
  std::vector<int> target;
  for (size_t t = 0; t < block->supernodes.size(); ++t) {
    const int k = block->supernodes[t];
    const int ncol = super()[k + 1] - super()[k];
    const int nrow = pi()[k + 1] - pi()[k];
    const int below = nrow - ncol;
    const double* lk = value() + px()[k];
    double* yk = y.data() + block->offsets[t];
    dtrsm_("L", "L", "N", "N", &ncol, &cols, &one, lk, &nrow, yk, &rows);
    if (below == 0) continue;
    work.resize(static_cast<size_t>(below) * cols);
    dgemm_("N",
           "N",
           &below,
           &cols,
           &ncol,
           &one,
           lk + ncol,
           &nrow,
           yk,
           &rows,
           &zero,
           work.data(),
           &below);
    target.resize(below);
    for (int i = 0; i < below; ++i) target[i] = local_row(row_index()[pi()[k] + ncol + i]);
    for (int j = 0; j < cols; ++j) {
      double* yj = y.data() + static_cast<long>(j) * rows;
      const double* wj = work.data() + static_cast<long>(j) * below;
      for (int i = 0; i < below; ++i) yj[target[i]] -= wj[i];
    }
  }
}

void SparseCholesky::Impl::BackwardSolve(const std::vector<int>& supernodes,
                                         const std::vector<int>& offsets,
                                         Eigen::MatrixXd* z) const {
  std::vector<int> position;
  Place(supernodes, offsets, &position);
  const int rows = static_cast<int>(z->rows());
  const int cols = static_cast<int>(z->cols());
  const double one = 1.0, minus_one = -1.0;
  std::vector<double> work;
  // Parents before children: subtract the off-diagonal block's transpose times the ancestors'
  // rows, then solve with the diagonal block's transpose.
  for (size_t t = supernodes.size(); t-- > 0;) {
    const int k = supernodes[t];
    const int ncol = super()[k + 1] - super()[k];
    const int nrow = pi()[k + 1] - pi()[k];
    const int below = nrow - ncol;
    const double* lk = value() + px()[k];
    double* zk = z->data() + offsets[t];
    if (below > 0) {
      work.resize(static_cast<size_t>(below) * cols);
      for (int i = 0; i < below; ++i) {
        const int r = row_index()[pi()[k] + ncol + i];
        const int u = column_supernode[r];
        TAC3D_DEMAND(position[u] >= 0);
        const double* source = z->data() + position[u] + r - super()[u];
        for (int j = 0; j < cols; ++j)
          work[i + static_cast<size_t>(j) * below] = source[static_cast<long>(j) * rows];
      }
      dgemm_("T",
             "N",
             &ncol,
             &cols,
             &below,
             &minus_one,
             lk + ncol,
             &nrow,
             work.data(),
             &below,
             &one,
             zk,
             &rows);
    }
    dtrsm_("L", "L", "T", "N", &ncol, &cols, &one, lk, &nrow, zk, &rows);
  }
}

namespace {

// Calls run(i, j, count) for each maximal run of supernodes common to both blocks that is
// consecutive in both, from a.supernodes[i] and b.supernodes[j]: rows a.offsets[i] ..
// a.offsets[i + count] of a and the as many from b.offsets[j] of b are the same rows of L.
template <typename Run>
void ForEachCommonRun(const std::vector<int>& a, const std::vector<int>& b, Run run) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (a[i] < b[j]) {
      ++i;
    } else if (b[j] < a[i]) {
      ++j;
    } else {
      const size_t i0 = i, j0 = j;
      do {
        ++i;
        ++j;
      } while (i < a.size() && j < b.size() && a[i] == b[j]);
      run(i0, j0, i - i0);
    }
  }
}

std::vector<int> UnionOfReaches(const std::vector<ColumnBlock>& blocks) {
  std::vector<int> all;
  for (const ColumnBlock& block : blocks)
    all.insert(all.end(), block.supernodes.begin(), block.supernodes.end());
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  return all;
}

}  // namespace

Eigen::MatrixXd SparseCholesky::CalcBilinear(const Eigen::SparseMatrix<double>& left,
                                             const Eigen::SparseMatrix<double>& right,
                                             Method method,
                                             int block_columns,
                                             const std::function<void(double)>& on_progress) const {
  const Impl& s = *impl_;
  TAC3D_DEMAND(left.rows() == s.n && right.rows() == s.n && block_columns >= 1);
  std::vector<ColumnBlock> blocks[2] = {s.MakeBlocks(left, block_columns),
                                        s.MakeBlocks(right, block_columns)};
  const Eigen::SparseMatrix<double>* sides[2] = {&left, &right};
  Eigen::MatrixXd result = Eigen::MatrixXd::Zero(left.cols(), right.cols());
  // result(column of side 0, column of side 1) for a column c of side `side` and d of the other.
  const auto entry = [&](int side, int c, int d) -> double& {
    return side == 0 ? result(c, d) : result(d, c);
  };

  // The flops of each way: both sides solved forward and multiplied where their reaches meet;
  // or one side forward, then backward on the union of the other side's reaches.
  double forward_flops[2] = {0.0, 0.0};
  std::vector<int> union_reach[2];
  for (int side : {0, 1}) {
    for (const ColumnBlock& block : blocks[side]) {
      forward_flops[side] +=
          s.SolveFlops(block.supernodes) * static_cast<double>(block.columns.size());
    }
    union_reach[side] = UnionOfReaches(blocks[side]);
  }
  double product_flops = 0.0;
  for (const ColumnBlock& a : blocks[0]) {
    for (const ColumnBlock& b : blocks[1]) {
      ForEachCommonRun(a.supernodes, b.supernodes, [&](size_t i, size_t, size_t count) {
        product_flops += 2.0 * static_cast<double>(a.columns.size()) *
                         static_cast<double>(b.columns.size()) *
                         (a.offsets[i + count] - a.offsets[i]);
      });
    }
  }
  const double both_forward = forward_flops[0] + forward_flops[1] + product_flops;
  double forward_backward[2];  // side forward, the other backward
  for (int side : {0, 1}) {
    forward_backward[side] = forward_flops[side] + static_cast<double>(sides[side]->cols()) *
                                                       s.SolveFlops(union_reach[1 - side]);
  }

  if (method == Method::kBothForward ||
      (method == Method::kCheapest &&
       both_forward <= std::min(forward_backward[0], forward_backward[1]))) {
    // The side with fewer columns is solved first and kept.
    const int kept_side = left.cols() <= right.cols() ? 0 : 1;
    const int streamed_side = 1 - kept_side;
    const double total = static_cast<double>(blocks[0].size() + blocks[1].size());
    double done = 0.0;
    for (ColumnBlock& a : blocks[kept_side]) {
      s.ForwardSolve(*sides[kept_side], &a);
      if (on_progress) on_progress(++done / total);
    }
    const double one = 1.0;
    Eigen::MatrixXd product;
    for (ColumnBlock& b : blocks[streamed_side]) {
      s.ForwardSolve(*sides[streamed_side], &b);
      const int nb = static_cast<int>(b.columns.size());
      const int ldb = static_cast<int>(b.y.rows());
      for (const ColumnBlock& a : blocks[kept_side]) {
        const int na = static_cast<int>(a.columns.size());
        const int lda = static_cast<int>(a.y.rows());
        product.setZero(na, nb);
        ForEachCommonRun(a.supernodes, b.supernodes, [&](size_t i, size_t j, size_t count) {
          const int length = a.offsets[i + count] - a.offsets[i];
          dgemm_("T",
                 "N",
                 &na,
                 &nb,
                 &length,
                 &one,
                 a.y.data() + a.offsets[i],
                 &lda,
                 b.y.data() + b.offsets[j],
                 &ldb,
                 &one,
                 product.data(),
                 &na);
        });
        for (int q = 0; q < nb; ++q) {
          for (int p = 0; p < na; ++p) entry(kept_side, a.columns[p], b.columns[q]) = product(p, q);
        }
      }
      b.y.resize(0, 0);
      if (on_progress) on_progress(++done / total);
    }
  } else {
    const int solved_side = forward_backward[0] <= forward_backward[1] ? 0 : 1;
    const int read_side = 1 - solved_side;
    const std::vector<int>& reach = union_reach[read_side];
    const std::vector<int> offsets = s.Offsets(reach);
    std::vector<int> position;
    s.Place(reach, offsets, &position);
    const Eigen::SparseMatrix<double>& read = *sides[read_side];
    const double total = static_cast<double>(blocks[solved_side].size());
    double done = 0.0;
    Eigen::MatrixXd z;
    for (ColumnBlock& b : blocks[solved_side]) {
      s.ForwardSolve(*sides[solved_side], &b);
      const int nb = static_cast<int>(b.columns.size());
      z.setZero(offsets.back(), nb);
      ForEachCommonRun(reach, b.supernodes, [&](size_t i, size_t j, size_t count) {
        z.middleRows(offsets[i], offsets[i + count] - offsets[i]) =
            b.y.middleRows(b.offsets[j], b.offsets[j + count] - b.offsets[j]);
      });
      b.y.resize(0, 0);
      s.BackwardSolve(reach, offsets, &z);
      for (int c = 0; c < read.cols(); ++c) {
        for (Eigen::SparseMatrix<double>::InnerIterator it(read, c); it; ++it) {
          const int k = s.permuted[it.row()];
          const int u = s.column_supernode[k];
          const int row = position[u] + k - s.super()[u];
          for (int q = 0; q < nb; ++q) entry(read_side, c, b.columns[q]) += it.value() * z(row, q);
        }
      }
      if (on_progress) on_progress(++done / total);
    }
  }
  return result;
}

}  // namespace tac3d::fem
