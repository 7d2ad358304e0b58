#pragma once

#include <Eigen/Core>
#include <memory>

#include "tac3d/fem/hex8.h"

namespace tac3d::contact {

/// A uniform grid of nx x ny square-ish cells on the contact surface, one node at each cell's
/// centre. Node (i, j) (i along x, j along y) has index j * nx + i and sits at
/// x = (i - (nx - 1) / 2) dx, y = (j - (ny - 1) / 2) dy, so the grid is centred on the origin.
struct SurfaceGrid {
  int nx = 0;
  int ny = 0;
  double dx_mm = 0.0;
  double dy_mm = 0.0;

  /// @throws tac3d::Error naming the field: nx, ny >= 3 (a contact needs an interior node),
  ///   dx_mm, dy_mm > 0 and finite.
  void Validate() const;
  int num_nodes() const { return nx * ny; }
  double cell_area_mm2() const { return dx_mm * dy_mm; }
  Eigen::Vector2d node_position_mm(int index) const;
  /// True if the node is on the outermost row or column.
  bool is_edge_node(int index) const;
};

/// Which components of a traction or displacement field: the two tangential ones (x, y) or the
/// normal one. Fields are n x k matrices, column c the component (x, y, normal).
enum class Components { kTangential, kNormal };

/// A linear surface compliance u = C p on a SurfaceGrid: displacement u (mm) of every node
/// under a traction p (MPa) uniform on every cell. Component order x, y, normal; the normal
/// traction is a pressure (positive in compression) and the normal displacement is positive
/// into the body (away from an indenter), so pressing makes both positive.
/// Implementations must be symmetric (Betti's reciprocity) and positive definite.
class ComplianceOperator {
 public:
  virtual ~ComplianceOperator() = default;
  virtual const SurfaceGrid& grid() const = 0;
  /// The block u_out = C_{out,in} p_in.
  /// @param traction n x 2 (kTangential) or n x 1 (kNormal), MPa.
  /// @return n x 2 or n x 1 displacements (mm).
  virtual Eigen::MatrixXd Apply(Components out,
                                Components in,
                                const Eigen::MatrixXd& traction) const = 0;
};

/// A compliance given as a dense 3n x 3n matrix (mm/MPa) in the project's component-major
/// order (x^1..x^n, y^1..y^n, normal^1..normal^n), e.g. the fingertip's FEM surface compliance
/// sampled on a SurfaceGrid. A compliance for nodal forces H (mm/N) is H * cell area.
class DenseCompliance final : public ComplianceOperator {
 public:
  /// @throws tac3d::Error if the grid is invalid, the matrix is not 3n x 3n, has non-finite
  ///   entries, or is not symmetric to 1e-9 of its largest entry.
  DenseCompliance(const SurfaceGrid& grid, Eigen::MatrixXd c_mm_per_mpa);
  const SurfaceGrid& grid() const override { return grid_; }
  Eigen::MatrixXd Apply(Components out,
                        Components in,
                        const Eigen::MatrixXd& traction) const override;

 private:
  SurfaceGrid grid_;
  Eigen::MatrixXd c_;
};

/// Displacement (mm) of an elastic half-space's surface point at offset (x, y) (mm, field minus
/// cell centre) from the centre of a dx x dy cell under a unit (1 MPa) uniform traction in
/// component `in`, component `out` of it. The closed-form integrals over the rectangle of the
/// Boussinesq and Cerruti point-load solutions (Johnson, Contact Mechanics, 1985, ch. 3; Love
/// 1929 for the normal-normal term). With
/// rho = sqrt(x^2 + y^2), E' = pi E / (1 + nu), the kernels integrated are
///   zz: (1 - nu) / (E' rho)                xx: [(1 - nu) / rho + nu x^2 / rho^3] / E'
///   xy: nu x y / (E' rho^3)               xz (u_x from pressure): -(1 - 2 nu) x / (2 E' rho^2)
/// and zx = -xz (u_z from a traction along x: the surface is pressed in ahead of it).
/// @param out, in component indices 0 = x, 1 = y, 2 = normal.
double CalcHalfSpaceInfluence(int out,
                              int in,
                              double x_mm,
                              double y_mm,
                              double dx_mm,
                              double dy_mm,
                              const fem::ElasticMaterial& material);

/// The compliance of a homogeneous elastic half-space (the thick-block limit) on a grid, as a
/// discrete convolution with the influence coefficients of CalcHalfSpaceInfluence, evaluated
/// with zero-padded FFTs (OpenCV's cv::dft) in O(n log n).
class HalfSpaceCompliance final : public ComplianceOperator {
 public:
  /// @throws tac3d::Error if the grid or the material is invalid.
  HalfSpaceCompliance(const SurfaceGrid& grid, const fem::ElasticMaterial& material);
  ~HalfSpaceCompliance() override;
  const SurfaceGrid& grid() const override { return grid_; }
  Eigen::MatrixXd Apply(Components out,
                        Components in,
                        const Eigen::MatrixXd& traction) const override;
  /// The same operator as a 3n x 3n matrix (DenseCompliance's order), by direct summation.
  Eigen::MatrixXd CalcDenseMatrix() const;

 private:
  struct Spectra;
  SurfaceGrid grid_;
  fem::ElasticMaterial material_;
  std::unique_ptr<Spectra> spectra_;
};

}  // namespace tac3d::contact
