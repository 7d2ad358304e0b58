#pragma once

#include "tac3d/util/eval_check.h"

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tac3d/fem/body_model.h"
#include "tac3d/fem/hex8.h"

namespace tac3d::fem {

/// Surface displacement (mm) of an elastic half-space z <= 0 (surface z = 0, z pointing out
/// of the body, as in the sensor frame) at surface point p (mm, p != 0) under a point force
/// (N) at the origin: Boussinesq for its normal part (force_n.z() < 0 presses into the body),
/// Cerruti for its tangential part (Johnson, Contact Mechanics, eqs. 3.19, 3.86 with z flipped).
/// With G the shear modulus and rho = |p|:
///   normal F_z:       u_t = F_z (1 - 2 nu) p / (4 pi G rho^2), u_z = F_z (1 - nu) / (2 pi G rho)
///   tangential Q:     u_t = [(1 - nu) Q / rho + nu (Q . p) p / rho^3] / (2 pi G),
///                     u_z = -(1 - 2 nu) (Q . p) / (4 pi G rho^2)
Eigen::Vector3d CalcHalfSpaceSurfaceDisplacement(const Eigen::Vector3d& force_n,
                                                 const ElasticMaterial& material,
                                                 const Eigen::Vector2d& p_mm);

/// Displacement patch test: a cube of 3 x 3 x 3 hex8 elements with its interior nodes moved
/// at random, every boundary node given the linear field u(x) = u0 + A x.
struct PatchTestOptions {
  double poisson_ratio = 0.3;
  /// Largest random move of an interior node, as a fraction of the element size.
  double distortion = 0.25;
  std::uint32_t seed = 20221122;
};

struct PatchTestResult {
  /// Largest |u_fem - u_exact| at the interior nodes (mm), the field being of order 1e-2 mm.
  double max_displacement_error_mm = 0.0;
  /// Largest |sigma_fem - sigma_exact| (any component, at every element's Gauss points and
  /// centre) over max |sigma_exact| (dimensionless).
  double max_relative_stress_error = 0.0;
};

PatchTestResult RunPatchTest(const PatchTestOptions& options);

/// A laterally confined block (normal displacement fixed on the four sides, base fixed) under
/// a uniform pressure on top; the FEM modulus pressure * height / settlement against the
/// constrained modulus E (1 - nu) / ((1 + nu)(1 - 2 nu)). Interior nodes are moved at random.
struct ConfinedBlockResult {
  double poisson_ratio = 0.0;
  double fem_modulus_mpa = 0.0;
  double exact_modulus_mpa = 0.0;
  double relative_error = 0.0;
};

ConfinedBlockResult RunConfinedBlock(double poisson_ratio);

/// A point force on a large block with a fixed base, against the half-space solution
/// (CalcHalfSpaceSurfaceDisplacement). The force is spread over a small square patch; one
/// quarter of the block is meshed (symmetry planes x = 0 and y = 0), fine near the load and
/// graded away from it.
struct PointLoadOptions {
  double poisson_ratio = 0.48;
  /// Normal (Boussinesq) or tangential along x (Cerruti).
  bool tangential = false;
  /// Half-width of the loaded square (mm).
  double patch_half_width_mm = 0.5;
  /// Element size near the load (mm) up to the patch edge, growing by grading_ratio beyond.
  double finest_element_mm = 0.25;
  double grading_ratio = 1.3;
  /// Size of the quarter block in x, y and depth (mm).
  double block_size_mm = 1000.0;
  /// Probe distances from the load (mm), on the surface at 0, 45 and 90 degrees from x.
  std::vector<double> probe_distances_mm = {3, 4, 5, 6, 7, 8};
  void Validate() const;
};

struct PointLoadProbe {
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();
  Eigen::Vector3d fem_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d exact_mm = Eigen::Vector3d::Zero();
  /// |fem - exact| / |exact|.
  double relative_error = 0.0;
};

struct PointLoadResult {
  std::vector<PointLoadProbe> probes;
  double max_relative_error = 0.0;
  int num_free_dofs = 0;
};

/// @throws tac3d::Error if the options are invalid.
PointLoadResult RunPointLoad(const PointLoadOptions& options);

/// H on the options' mesh against H on a mesh refined by `refinement` (relative Frobenius
/// norm of the difference, over the finer H's norm).
struct MeshConvergenceResult {
  double relative_difference = 0.0;
  int coarse_free_dofs = 0;
  int fine_free_dofs = 0;
  double coarse_build_s = 0.0;
  double fine_build_s = 0.0;
};

/// @param cache_dir where both models are loaded from or cached (LoadOrBuildComplianceModel);
///   empty = build both. The build times are those of the original builds.
/// @throws tac3d::Error if the options (or refined options) are invalid.
MeshConvergenceResult RunMeshConvergence(const BodyModelOptions& options,
                                         double refinement,
                                         const std::string& cache_dir = "",
                                         bool show_progress = false);

/// What `tac3d eval fem` checks.
struct EvalFemOptions {
  /// The sensor whose model is built (or loaded from cache_dir) and refined.
  BodyModelOptions body;
  /// Where H is cached; empty = build without caching.
  std::string cache_dir;
  /// Refinement of the convergence check; 0 = skip it (it builds a model ~3.4x larger).
  double convergence_refinement = 1.5;
  bool show_progress = true;

  /// @throws tac3d::Error naming the field: convergence_refinement must be 0 or > 1, and the
  ///   body options must be valid.
  void Validate() const;
};

/// What EvaluateFem measured.
struct EvalFemResult {
  /// The patch tests (nu 0.3, 0.4999: interior displacement, stress), the confined block
  /// (nu 0.3, 0.48, 0.499), the point loads (Boussinesq and Cerruti at nu 0.3, 0.48) and, unless
  /// skipped, the mesh convergence of H; all "at most" their tolerance.
  std::vector<EvalCheck> checks;
  bool all_pass = false;
  /// The sensor's H: where it came from and how it was built.
  nlohmann::json model;
  /// Each check's own figures (exact and FEM modulus, free DOFs, build times), by check name.
  nlohmann::json details;

  /// The checks as the CLI prints them, the model and the verdict.
  std::string Report() const;
};

/// {"checks": [the check's JSON with its details' fields], "model", "all_pass"}.
nlohmann::json ToJson(const EvalFemResult& result);

/// Runs the patch test, the confined block, the point loads, builds or loads the sensor's H
/// and the mesh convergence check (EvalFemResult).
/// @throws tac3d::Error if the options are invalid.
EvalFemResult EvaluateFem(const EvalFemOptions& options);

}  // namespace tac3d::fem
