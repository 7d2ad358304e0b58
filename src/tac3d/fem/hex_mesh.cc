#include "tac3d/fem/hex_mesh.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d::fem {

Hex8Nodes HexMesh::ElementNodes(int e) const {
  Hex8Nodes x;
  for (int a = 0; a < 8; ++a) x.row(a) = nodes[elements[e][a]].transpose();
  return x;
}

double CalcMinJacobianDeterminant(const HexMesh& mesh) {
  double min_det = std::numeric_limits<double>::infinity();
  for (int e = 0; e < mesh.num_elements(); ++e) {
    min_det = std::min(min_det, CalcHex8MinJacobianDeterminant(mesh.ElementNodes(e)));
  }
  return min_det;
}

HexMesh BuildBoxMesh(const std::vector<double>& x_coords,
                     const std::vector<double>& y_coords,
                     const std::vector<double>& z_coords) {
  for (const auto* coords : {&x_coords, &y_coords, &z_coords}) {
    if (coords->size() < 2) throw Error("BuildBoxMesh: a coordinate list needs >= 2 entries");
    for (size_t i = 1; i < coords->size(); ++i) {
      if (!((*coords)[i] > (*coords)[i - 1])) {
        throw Error(fmt::format("BuildBoxMesh: coordinates must increase (entry {})", i));
      }
    }
  }
  const int nx = static_cast<int>(x_coords.size());
  const int ny = static_cast<int>(y_coords.size());
  const int nz = static_cast<int>(z_coords.size());
  HexMesh mesh;
  mesh.nodes.reserve(static_cast<size_t>(nx) * ny * nz);
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        mesh.nodes.emplace_back(x_coords[i], y_coords[j], z_coords[k]);
      }
    }
  }
  const auto id = [&](int i, int j, int k) { return (k * ny + j) * nx + i; };
  for (int k = 0; k + 1 < nz; ++k) {
    for (int j = 0; j + 1 < ny; ++j) {
      for (int i = 0; i + 1 < nx; ++i) {
        mesh.elements.push_back({id(i, j, k),
                                 id(i + 1, j, k),
                                 id(i + 1, j + 1, k),
                                 id(i, j + 1, k),
                                 id(i, j, k + 1),
                                 id(i + 1, j, k + 1),
                                 id(i + 1, j + 1, k + 1),
                                 id(i, j + 1, k + 1)});
      }
    }
  }
  return mesh;
}

std::optional<Eigen::Vector3d> CalcHex8InverseMap(const Hex8Nodes& x, const Eigen::Vector3d& p) {
  const double scale = (x.colwise().maxCoeff() - x.colwise().minCoeff()).norm();
  Eigen::Vector3d xi = Eigen::Vector3d::Zero();
  for (int iteration = 0; iteration < 30; ++iteration) {
    const Eigen::Vector3d residual = x.transpose() * CalcHex8Shape(xi) - p;
    if (residual.norm() <= 1e-13 * scale) return xi;
    // dx/dxi = J^T with J(i, j) = dx_j / dxi_i.
    const Eigen::Matrix3d dx_dxi = x.transpose() * CalcHex8ShapeDerivatives(xi);
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(dx_dxi);
    if (!lu.isInvertible()) return std::nullopt;
    xi -= lu.solve(residual);
    // Far outside the element Newton may wander; such points are not in it anyway.
    if (xi.cwiseAbs().maxCoeff() > 10.0) return std::nullopt;
  }
  return std::nullopt;
}

PointLocator::PointLocator(const HexMesh& mesh) : mesh_(mesh) {
  TAC3D_DEMAND(mesh.num_elements() > 0);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : mesh.nodes) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // About two elements a cell on average.
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-3 * (hi - lo).maxCoeff());
  const double cell = std::cbrt(extent.prod() / std::max(1.0, mesh.num_elements() / 2.0));
  origin_ = lo;
  for (int i = 0; i < 3; ++i) {
    dims_(i) = std::clamp(static_cast<int>(std::ceil(extent(i) / cell)), 1, 512);
    cell_size_(i) = extent(i) / dims_(i);
  }
  const auto cell_of = [&](const Eigen::Vector3d& p) {
    Eigen::Vector3i c;
    for (int i = 0; i < 3; ++i) {
      c(i) = std::clamp(
          static_cast<int>(std::floor((p(i) - origin_(i)) / cell_size_(i))), 0, dims_(i) - 1);
    }
    return c;
  };
  const int num_cells = dims_.prod();
  std::vector<std::vector<int>> buckets(num_cells);
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const Hex8Nodes x = mesh.ElementNodes(e);
    const Eigen::Vector3i c0 = cell_of(x.colwise().minCoeff().transpose());
    const Eigen::Vector3i c1 = cell_of(x.colwise().maxCoeff().transpose());
    for (int k = c0(2); k <= c1(2); ++k) {
      for (int j = c0(1); j <= c1(1); ++j) {
        for (int i = c0(0); i <= c1(0); ++i) {
          buckets[(k * dims_(1) + j) * dims_(0) + i].push_back(e);
        }
      }
    }
  }
  cell_start_.assign(num_cells + 1, 0);
  for (int c = 0; c < num_cells; ++c) {
    cell_start_[c + 1] = cell_start_[c] + static_cast<int>(buckets[c].size());
  }
  cell_elements_.reserve(cell_start_.back());
  for (const auto& bucket : buckets) {
    cell_elements_.insert(cell_elements_.end(), bucket.begin(), bucket.end());
  }
}

std::optional<ElementPoint> PointLocator::Locate(const Eigen::Vector3d& p, double tolerance) const {
  Eigen::Vector3i c;
  for (int i = 0; i < 3; ++i) {
    const double t = std::floor((p(i) - origin_(i)) / cell_size_(i));
    // A point a hair outside the bounding box still belongs to the boundary cells.
    if (t < -1.0 || t > dims_(i)) return std::nullopt;
    c(i) = std::clamp(static_cast<int>(t), 0, dims_(i) - 1);
  }
  const int cell = (c(2) * dims_(1) + c(1)) * dims_(0) + c(0);
  std::optional<ElementPoint> best;
  double best_excess = std::numeric_limits<double>::infinity();
  for (int k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
    const int e = cell_elements_[k];
    const std::optional<Eigen::Vector3d> xi = CalcHex8InverseMap(mesh_.ElementNodes(e), p);
    if (!xi) continue;
    const double excess = xi->cwiseAbs().maxCoeff() - 1.0;
    if (excess <= tolerance && excess < best_excess) {
      best_excess = excess;
      best = ElementPoint{e, *xi};
    }
  }
  return best;
}

Eigen::SparseMatrix<double> CalcInterpolationMatrix(const HexMesh& mesh,
                                                    const std::vector<ElementPoint>& points) {
  const int num_points = static_cast<int>(points.size());
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(24 * points.size());
  for (int p = 0; p < num_points; ++p) {
    TAC3D_DEMAND(points[p].element >= 0 && points[p].element < mesh.num_elements());
    const Eigen::Matrix<double, 8, 1> n = CalcHex8Shape(points[p].xi);
    for (int a = 0; a < 8; ++a) {
      const int node = mesh.elements[points[p].element][a];
      for (int c = 0; c < 3; ++c) triplets.emplace_back(c * num_points + p, 3 * node + c, n(a));
    }
  }
  Eigen::SparseMatrix<double> interpolation(3 * num_points, mesh.num_dofs());
  interpolation.setFromTriplets(triplets.begin(), triplets.end());
  return interpolation;
}

}  // namespace tac3d::fem
