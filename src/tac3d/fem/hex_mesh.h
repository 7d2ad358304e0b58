#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <optional>
#include <vector>

#include "tac3d/fem/hex8.h"

namespace tac3d::fem {

/// A mesh of 8-node hexahedra (node order as Hex8Nodes). Nodal vectors on it are laid out
/// node-major: DOF 3 * node + component, component 0, 1, 2 = x, y, z.
struct HexMesh {
  /// Node positions (mm).
  std::vector<Eigen::Vector3d> nodes;
  /// Node indices of each element.
  std::vector<std::array<int, 8>> elements;

  int num_nodes() const { return static_cast<int>(nodes.size()); }
  int num_elements() const { return static_cast<int>(elements.size()); }
  int num_dofs() const { return 3 * num_nodes(); }
  /// The corner coordinates of element e.
  Hex8Nodes ElementNodes(int e) const;
};

/// The smallest Jacobian determinant of any element (at its corners and Gauss points);
/// positive for a valid mesh.
double CalcMinJacobianDeterminant(const HexMesh& mesh);

/// A tensor-product box mesh on the grid x_coords x y_coords x z_coords (mm, each strictly
/// increasing). Node (i, j, k) has index (k * ny + j) * nx + i; element (i, j, k) has index
/// (k * (ny - 1) + j) * (nx - 1) + i and its top face (zeta = +1) towards +z.
/// @throws tac3d::Error if a coordinate list has fewer than 2 entries or does not increase.
HexMesh BuildBoxMesh(const std::vector<double>& x_coords,
                     const std::vector<double>& y_coords,
                     const std::vector<double>& z_coords);

/// A point inside a mesh: its element and parametric coordinates there.
struct ElementPoint {
  int element = -1;
  Eigen::Vector3d xi = Eigen::Vector3d::Zero();
};

/// Finds the element that contains a point (a bucket grid over element bounding boxes, then
/// the inverse isoparametric map by Newton's method). Holds a reference to the mesh, which
/// must outlive it.
class PointLocator {
 public:
  explicit PointLocator(const HexMesh& mesh);

  /// The element holding p (mm) and its parametric coordinates, accepting |xi_i| <= 1 +
  /// tolerance (so points on faces, or a hair outside a curved surface the bilinear faces
  /// approximate, are found); nullopt if no element holds it.
  std::optional<ElementPoint> Locate(const Eigen::Vector3d& p, double tolerance = 1e-6) const;

 private:
  const HexMesh& mesh_;
  Eigen::Vector3d origin_;
  Eigen::Vector3d cell_size_;
  Eigen::Vector3i dims_;
  std::vector<int> cell_start_;     // CSR over cells into cell_elements_
  std::vector<int> cell_elements_;  // element indices
};

/// The parametric coordinates of p in element x by Newton's method on x(xi) = p, started at
/// the centre; nullopt if Newton does not converge (p far outside a distorted element).
std::optional<Eigen::Vector3d> CalcHex8InverseMap(const Hex8Nodes& x, const Eigen::Vector3d& p);

/// The sparse interpolation matrix (3 P x num_dofs) that maps nodal displacements to the
/// displacements at P located points, rows component-major: row c * P + p.
Eigen::SparseMatrix<double> CalcInterpolationMatrix(const HexMesh& mesh,
                                                    const std::vector<ElementPoint>& points);

}  // namespace tac3d::fem
