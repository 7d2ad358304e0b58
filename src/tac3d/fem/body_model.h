#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/fem/elastic_solver.h"
#include "tac3d/fem/hex8.h"
#include "tac3d/fem/hex_mesh.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d::fem {

/// How the lateral face of the dome (the cylinder r = base radius) is held.
enum class LateralBoundary { kFree, kFixed };

/// The silicone fingertip of a Tac3D sensor and its FEM mesh, in the sensor frame (mm):
/// the base is a disc in the horizontal plane through base_center_mm bonded to the rigid
/// glass plate (every base node fixed); the outer surface is a sphere whose top is thickness
/// above the base on the axis (the vertical line through base_center_mm); the lateral face is
/// the cylinder r = base radius about the axis between the two. Markers sit on a square grid
/// on the sphere concentric with the outer surface, marker_depth below it, or where
/// marker_positions_mm puts them (a real sensor's measured rest positions). Defaults are the
/// paper's prototype (Zhang et al., Tac3D, section III.A and IV.A).
struct BodyModelOptions {
  /// Diameter of the base disc (mm).
  double base_diameter_mm = 40.0;
  /// Height of the outer surface on the axis (mm), the paper's d.
  double thickness_mm = 8.0;
  /// Radius of the spherical outer surface (mm).
  double sphere_radius_mm = 45.0;
  LateralBoundary lateral_boundary = LateralBoundary::kFree;
  ElasticMaterial material;
  /// Marker grid: marker (row i, col j) at x = (j - (cols-1)/2) pitch,
  /// y = (i - (rows-1)/2) pitch, index i * cols + j.
  int marker_rows = 20;
  int marker_cols = 20;
  double marker_pitch_mm = 1.27;
  /// Depth of the marker layer under the outer surface, along the sphere's radius (mm).
  double marker_depth_mm = 0.5;
  /// Multiplies the element count in every direction; 1 = the paper's mesh (in-plane edge
  /// pitch / 3 under the sensing area).
  double refinement = 1.0;
  /// Centre of the base disc (mm, sensor frame); the prototype's is the origin, an imported
  /// sensor's is under its dome's fitted centre, on its refraction plane.
  Eigen::Vector3d base_center_mm = Eigen::Vector3d::Zero();
  /// The markers' rest positions (mm, sensor frame) in index order, or empty for the square
  /// grid above. Given, they replace the grid (marker_depth_mm then only records how deep the
  /// outer surface was put above them); the central mesh block then spans their load patches.
  std::vector<Eigen::Vector3d> marker_positions_mm;

  /// @throws tac3d::Error naming the field and the bound it breaks: every length > 0;
  ///   sphere radius > base radius and the sphere above z = 0 at the rim; the marker grid's
  ///   load patches (a square of half-width max(rows, cols) pitch / 2) inside the base with
  ///   its corners within 0.95 of the base radius; 0 < marker depth < the body's height at the
  ///   outermost marker; rows, cols in [1, 200]; refinement in [0.25, 4]; the material's bounds;
  ///   base_center_mm finite; given marker positions: rows x cols of them, each finite and
  ///   inside the body (its radius from the axis within 0.95 of the base radius, above the base
  ///   and under the outer surface).
  void Validate() const;

  double base_radius_mm() const { return 0.5 * base_diameter_mm; }
  /// z of the sphere's centre (mm, relative to the base plane), on the axis below the base.
  double sphere_center_z_mm() const { return thickness_mm - sphere_radius_mm; }
  /// Height of the outer surface above the base at radius r from the axis (mm).
  double SurfaceHeight(double r_mm) const;
  int num_markers() const { return marker_rows * marker_cols; }
};

/// The body a SensorConfig describes (elastic body, markers), at refinement 1.
BodyModelOptions BodyModelOptionsFromSensor(const SensorConfig& config);

/// Every option; base_center_mm and marker_positions_mm only when not their defaults, so a
/// prototype's JSON (and its compliance cache key) is what it was before they existed.
nlohmann::json ToJson(const BodyModelOptions& options);
/// @throws tac3d::Error on a missing field or a wrong type.
BodyModelOptions BodyModelOptionsFromJson(const nlohmann::json& json);

/// Marker positions (mm, sensor frame) in index order i * cols + j: marker_positions_mm if
/// given, else the grid.
std::vector<Eigen::Vector3d> CalcMarkerPositions(const BodyModelOptions& options);

/// The dome's hexahedral mesh: an O-grid in the base plane (a square block of uniform spacing
/// aligned with the marker pitch under the marker grid, four graded ring blocks mapped onto the
/// base circle) extruded along z in layers that follow the sphere, finest at the outer surface.
struct DomeMesh {
  HexMesh mesh;
  /// One flag a DOF: the base nodes, and the lateral face's nodes if it is fixed.
  std::vector<bool> fixed;
  /// Elements whose top face (zeta = +1) lies on the outer surface.
  std::vector<int> outer_surface_elements;
  /// Half-width (mm) and elements a side of the central square block, centred on the axis.
  double central_half_width_mm = 0.0;
  int central_elements = 0;
  int ring_elements = 0;
  int layers = 0;

  /// The outer-surface element above central cell (i, j) (x index i, y index j).
  int CentralTopElement(int i, int j) const;
};

/// @throws tac3d::Error if the options are invalid.
/// @post every element's Jacobian is positive (TAC3D_DEMAND).
DomeMesh BuildDomeMesh(const BodyModelOptions& options);

/// How a BodyModel solves: directly (ElasticSolverMethod::kDirect) up to a size, by two-grid
/// preconditioned conjugate gradients (kTwoGridPcg; MINRES on the mixed form,
/// kTwoGridMixedMinres, with PcgOptions::mixed_form) on larger meshes, whose
/// direct factor does not fit (refinement 2 of the default dome: CHOLMOD's 32-bit indices
/// overflow, and ~20 GB).
struct BodySolverOptions {
  /// kDirect up to this many free DOFs, iterative above it: the default dome is direct up to
  /// refinement 1.5 (559,482 free DOFs, 6.8 GB) and iterative at 2 (1,257,174). 0 = always
  /// iterative.
  int max_direct_free_dofs = 600000;
  /// The coarse level is the same dome at the refinement divided by this (2: every coarse edge
  /// spans two fine ones; refinement 2 -> the nominal mesh).
  double coarsening_ratio = 2.0;
  PcgOptions pcg;

  /// @throws tac3d::Error naming the field: max_direct_free_dofs >= 0, coarsening_ratio > 1,
  ///   and the PCG options' bounds.
  void Validate() const;
};

/// The dome meshed and assembled once (and factored, or with its coarse level factored):
/// displacements for any loads, at any points. The digital twin uses it for the surface
/// compliance of a finer mesh; the compliance matrix H of the paper's eq. (1) is
/// CalcComplianceModel (compliance.h).
class BodyModel {
 public:
  /// @throws tac3d::Error if the options are invalid, the coarse level's refinement
  ///   (kTwoGridPcg) is below 0.25, or the solver's construction fails (ElasticSolver).
  explicit BodyModel(const BodyModelOptions& options,
                     bool show_progress = false,
                     const BodySolverOptions& solver = {});
  BodyModel(const BodyModel&) = delete;
  BodyModel& operator=(const BodyModel&) = delete;

  const BodyModelOptions& options() const { return options_; }
  const DomeMesh& dome() const { return dome_; }
  const HexMesh& mesh() const { return dome_.mesh; }
  const ElasticSolver& solver() const { return solver_; }
  const std::vector<Eigen::Vector3d>& marker_positions() const { return marker_positions_; }

  /// Nodal forces (num_dofs x 3N) for a unit force (1 N) in x, y, z spread uniformly by area
  /// over the outer-surface patch of each marker, the pitch x pitch square around the
  /// marker's (x, y) on the sphere (clipped to the central block); column c * N + k for direction c, marker k (eq. 1's F).
  Eigen::SparseMatrix<double> CalcMarkerPatchLoads() const;

  /// The interpolation (3 P x num_dofs, rows c * P + p) of the displacement at P points.
  /// @throws tac3d::Error naming the first point that is not inside the body.
  Eigen::SparseMatrix<double> CalcPointInterpolation(
      const std::vector<Eigen::Vector3d>& points_mm) const;

 private:
  BodyModelOptions options_;
  DomeMesh dome_;
  ElasticSolver solver_;
  PointLocator locator_;
  std::vector<Eigen::Vector3d> marker_positions_;
};

}  // namespace tac3d::fem
