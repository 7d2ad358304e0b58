#pragma once

#include <Eigen/Core>
#include <memory>

#include "tac3d/material/elastic_material.h"

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
  /// The compliance among the nodes of an nx x ny block of the grid (the operator's principal
  /// submatrix, on a grid of that size with the same spacing) if it is the same wherever the
  /// block lies, as a convolution's is; null otherwise. A contact solver can then work on a
  /// window around the contact instead of the whole grid.
  virtual std::shared_ptr<const ComplianceOperator> Window(int /*nx*/, int /*ny*/) const {
    return nullptr;
  }
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
                              const ElasticMaterial& material);

/// A translation-invariant kernel sampled at every offset between two nodes of a grid:
/// k[out][in] is (2 ny - 1) x (2 nx - 1), entry (dj + ny - 1, di + nx - 1) the displacement
/// component `out` (mm) at the node offset by (di dx, dj dy) from a cell loaded by 1 MPa in
/// component `in` (ComplianceOperator's components and signs).
struct SampledKernel {
  Eigen::MatrixXd k[3][3];

  /// Zero kernels of the right size for the grid.
  static SampledKernel Zero(const SurfaceGrid& grid);
  double& at(int out, int in, int di, int dj);
  double at(int out, int in, int di, int dj) const;
};

/// How positive the Fourier symbol of a convolution compliance is: at every frequency of the
/// zero-padded FFT the 3 x 3 Hermitian matrix S(w) = sum_d K(d) exp(-i w.d) (Hermitian because
/// K_ab(d) = K_ba(-d)); the circulant operator is positive definite iff every S(w) is, and the
/// grid's operator is a principal block of it.
struct KernelSymbolReport {
  int num_frequencies = 0;
  double min_eigenvalue = 0.0;  ///< mm/MPa
  double max_eigenvalue = 0.0;
  /// Eigenvalues raised to the floor (ConvolutionCompliance's clamp_floor), 0 if not clamped.
  int num_clamped = 0;
};

/// A compliance that is a discrete convolution with a sampled kernel on a grid, evaluated with
/// zero-padded FFTs (OpenCV's cv::dft) in O(n log n): the half-space's, or the twin's kernel
/// sampled from its FEM body.
class ConvolutionCompliance final : public ComplianceOperator {
 public:
  /// @param clamp_floor if > 0, symbol eigenvalues below clamp_floor times the largest are
  ///   raised to it (S := V max(L, floor) V^H), making the operator positive definite; a
  ///   sampled kernel's tiny negative eigenvalues (rounding, truncation) are removed that way.
  /// @throws tac3d::Error if the grid is invalid, a kernel has the wrong size or non-finite
  ///   entries, it is not reciprocal (K_ab(d) = K_ba(-d) to 1e-9 of its largest entry), or
  ///   clamp_floor is not in [0, 1).
  ConvolutionCompliance(const SurfaceGrid& grid,
                        const SampledKernel& kernel,
                        double clamp_floor = 0.0);
  ~ConvolutionCompliance() override;
  const SurfaceGrid& grid() const override { return grid_; }
  Eigen::MatrixXd Apply(Components out,
                        Components in,
                        const Eigen::MatrixXd& traction) const override;
  /// The kernel as used, cropped to the block's offsets (a principal submatrix of a positive
  /// definite operator is positive definite, so no clamping).
  /// @pre 3 <= nx <= grid().nx, 3 <= ny <= grid().ny.
  std::shared_ptr<const ComplianceOperator> Window(int nx, int ny) const override;
  /// The operator as a 3n x 3n matrix (DenseCompliance's order), from the kernel as clamped.
  Eigen::MatrixXd CalcDenseMatrix() const;
  /// The kernel as used (after clamping).
  const SampledKernel& kernel() const { return kernel_; }
  /// The symbol's eigenvalues before clamping.
  const KernelSymbolReport& symbol_report() const { return symbol_report_; }

 private:
  struct Spectra;
  SurfaceGrid grid_;
  SampledKernel kernel_;
  KernelSymbolReport symbol_report_;
  std::unique_ptr<Spectra> spectra_;
};

/// The compliance of a homogeneous elastic half-space (the thick-block limit) on a grid: the
/// convolution (ConvolutionCompliance) with the influence coefficients of
/// CalcHalfSpaceInfluence.
class HalfSpaceCompliance final : public ComplianceOperator {
 public:
  /// @throws tac3d::Error if the grid or the material is invalid.
  HalfSpaceCompliance(const SurfaceGrid& grid, const ElasticMaterial& material);
  const SurfaceGrid& grid() const override { return convolution_.grid(); }
  Eigen::MatrixXd Apply(Components out,
                        Components in,
                        const Eigen::MatrixXd& traction) const override {
    return convolution_.Apply(out, in, traction);
  }
  std::shared_ptr<const ComplianceOperator> Window(int nx, int ny) const override {
    return convolution_.Window(nx, ny);
  }
  /// The same operator as a 3n x 3n matrix (DenseCompliance's order), by direct summation.
  Eigen::MatrixXd CalcDenseMatrix() const { return convolution_.CalcDenseMatrix(); }

 private:
  ConvolutionCompliance convolution_;
};

}  // namespace tac3d::contact
