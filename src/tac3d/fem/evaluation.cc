#include "tac3d/fem/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "tac3d/fem/compliance.h"
#include "tac3d/fem/elastic_solver.h"
#include "tac3d/fem/hex_mesh.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"

namespace tac3d::fem {
namespace {

// Tolerances of EvaluateFem's checks.
constexpr double kPatchDisplacementTolerance = 1e-10;  // mm
constexpr double kPatchStressTolerance = 1e-8;         // relative
constexpr double kConfinedTolerance = 0.01;
constexpr double kPointLoadTolerance = 0.10;
constexpr double kConvergenceTolerance = 0.03;

std::vector<double> Uniform(double length, int n) {
  std::vector<double> coords(n + 1);
  for (int i = 0; i <= n; ++i) coords[i] = length * i / n;
  return coords;
}

// Moves the nodes strictly inside the box [lo, hi] by up to `amount` per axis, at random.
void DistortInterior(HexMesh* mesh,
                     const Eigen::Vector3d& lo,
                     const Eigen::Vector3d& hi,
                     double amount,
                     std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> move(-amount, amount);
  constexpr double kEps = 1e-9;
  for (Eigen::Vector3d& p : mesh->nodes) {
    const bool interior = ((p - lo).array() > kEps).all() && ((hi - p).array() > kEps).all();
    if (interior) p += Eigen::Vector3d(move(rng), move(rng), move(rng));
  }
}

// Nodal forces (N) of a uniform traction (MPa) on the top faces of the given elements, over
// the parametric part [-1, 1]^2 of each.
Eigen::VectorXd TopTractionLoads(const HexMesh& mesh,
                                 const std::vector<int>& elements,
                                 const Eigen::Vector3d& traction_mpa) {
  Eigen::VectorXd f = Eigen::VectorXd::Zero(mesh.num_dofs());
  for (int e : elements) {
    const TopFaceIntegrals face = IntegrateHex8TopFace(mesh.ElementNodes(e), -1, 1, -1, 1);
    for (int a = 0; a < 4; ++a) {
      f.segment<3>(3 * mesh.elements[e][4 + a]) += face.shape_integrals(a) * traction_mpa;
    }
  }
  return f;
}

// Box mesh elements in the top layer.
std::vector<int> TopLayer(int nx, int ny, int nz) {
  std::vector<int> top;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) top.push_back(((nz - 1) * ny + j) * nx + i);
  }
  return top;
}

// 0, h, 2h, ... up to `fine` (a multiple of h), then steps growing by `ratio` up to `length`;
// the last step is stretched or merged so the list ends exactly at `length`.
std::vector<double> FineThenGraded(double h, double fine, double length, double ratio) {
  std::vector<double> coords = {0.0};
  const int n_fine = static_cast<int>(std::lround(fine / h));
  for (int i = 1; i <= n_fine; ++i) coords.push_back(i * h);
  double step = h;
  while (coords.back() < length) {
    step *= ratio;
    coords.push_back(coords.back() + step);
  }
  // Snap the end to `length`; drop a last sliver less than half a step.
  if (coords.back() - length > 0.5 * step && coords.size() > 2) coords.pop_back();
  coords.back() = length;
  return coords;
}

void Report(const EvalFemOptions& options, const EvalCheck& check) {
  if (options.show_progress) std::fprintf(stderr, "fem eval: %s\n", check.Format().c_str());
}

}  // namespace

Eigen::Vector3d CalcHalfSpaceSurfaceDisplacement(const Eigen::Vector3d& force_n,
                                                 const ElasticMaterial& material,
                                                 const Eigen::Vector2d& p_mm) {
  const double rho = p_mm.norm();
  TAC3D_DEMAND(rho > 0.0);
  const double nu = material.poisson_ratio;
  const double g = material.shear_modulus();
  const double pi = std::numbers::pi;
  const Eigen::Vector2d q = force_n.head<2>();
  const double fz = force_n.z();
  const Eigen::Vector2d tangential =
      fz * (1.0 - 2.0 * nu) / (4.0 * pi * g * rho * rho) * p_mm +
      ((1.0 - nu) / rho * q + nu * q.dot(p_mm) / (rho * rho * rho) * p_mm) / (2.0 * pi * g);
  const double normal = fz * (1.0 - nu) / (2.0 * pi * g * rho) -
                        (1.0 - 2.0 * nu) * q.dot(p_mm) / (4.0 * pi * g * rho * rho);
  return Eigen::Vector3d(tangential.x(), tangential.y(), normal);
}

PatchTestResult RunPatchTest(const PatchTestOptions& options) {
  const int n = 3;
  const double size = 3.0;
  HexMesh mesh = BuildBoxMesh(Uniform(size, n), Uniform(size, n), Uniform(size, n));
  DistortInterior(&mesh,
                  Eigen::Vector3d::Zero(),
                  Eigen::Vector3d::Constant(size),
                  options.distortion * size / n,
                  options.seed);
  TAC3D_DEMAND(CalcMinJacobianDeterminant(mesh) > 0.0);
  const ElasticMaterial material{1.0, options.poisson_ratio};

  Eigen::Matrix3d a;
  a << 1.0, -0.4, 0.3, 0.2, -0.7, 0.5, -0.6, 0.1, 0.8;
  a *= 1e-2;
  const Eigen::Vector3d u0(0.01, -0.02, 0.005);
  Eigen::VectorXd exact(mesh.num_dofs());
  std::vector<bool> fixed(mesh.num_dofs(), false);
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    const Eigen::Vector3d& p = mesh.nodes[node];
    exact.segment<3>(3 * node) = u0 + a * p;
    const bool boundary = (p.array() < 1e-9).any() || (p.array() > size - 1e-9).any();
    for (int c = 0; c < 3; ++c) fixed[3 * node + c] = boundary;
  }
  const ElasticSolver solver(mesh, material, fixed);
  const Eigen::VectorXd u = solver.Solve(Eigen::VectorXd::Zero(mesh.num_dofs()), exact);

  PatchTestResult result;
  result.max_displacement_error_mm = (u - exact).cwiseAbs().maxCoeff();
  const Eigen::Matrix3d strain = 0.5 * (a + a.transpose());
  const Eigen::Matrix3d exact_stress =
      2.0 * material.shear_modulus() * strain +
      (material.bulk_modulus() - 2.0 / 3.0 * material.shear_modulus()) * strain.trace() *
          Eigen::Matrix3d::Identity();
  const double g = 1.0 / std::sqrt(3.0);
  for (int e = 0; e < mesh.num_elements(); ++e) {
    Hex8Vector ue;
    for (int k = 0; k < 8; ++k) ue.segment<3>(3 * k) = u.segment<3>(3 * mesh.elements[e][k]);
    std::vector<Eigen::Vector3d> points = {Eigen::Vector3d::Zero()};
    for (int k = 0; k < 8; ++k) {
      points.emplace_back(k & 1 ? g : -g, k & 2 ? g : -g, k & 4 ? g : -g);
    }
    for (const Eigen::Vector3d& xi : points) {
      const Eigen::Matrix3d stress = CalcHex8Stress(mesh.ElementNodes(e), ue, material, xi);
      result.max_relative_stress_error = std::max(
          result.max_relative_stress_error,
          (stress - exact_stress).cwiseAbs().maxCoeff() / exact_stress.cwiseAbs().maxCoeff());
    }
  }
  return result;
}

ConfinedBlockResult RunConfinedBlock(double poisson_ratio) {
  const int n = 4;
  const double width = 10.0, height = 6.0, pressure = 0.01;
  HexMesh mesh = BuildBoxMesh(Uniform(width, n), Uniform(width, n), Uniform(height, n));
  DistortInterior(
      &mesh, Eigen::Vector3d::Zero(), Eigen::Vector3d(width, width, height), 0.2 * height / n, 7);
  const ElasticMaterial material{1.0, poisson_ratio};
  std::vector<bool> fixed(mesh.num_dofs(), false);
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    const Eigen::Vector3d& p = mesh.nodes[node];
    if (p.z() < 1e-9) {
      for (int c = 0; c < 3; ++c) fixed[3 * node + c] = true;
    }
    if (p.x() < 1e-9 || p.x() > width - 1e-9) fixed[3 * node + 0] = true;
    if (p.y() < 1e-9 || p.y() > width - 1e-9) fixed[3 * node + 1] = true;
  }
  const ElasticSolver solver(mesh, material, fixed);
  const Eigen::VectorXd u =
      solver.Solve(TopTractionLoads(mesh, TopLayer(n, n, n), Eigen::Vector3d(0, 0, -pressure)));
  double settlement = 0.0;
  int top_nodes = 0;
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    if (mesh.nodes[node].z() > height - 1e-9) {
      settlement -= u(3 * node + 2);
      ++top_nodes;
    }
  }
  settlement /= top_nodes;
  ConfinedBlockResult result;
  result.poisson_ratio = poisson_ratio;
  result.fem_modulus_mpa = pressure * height / settlement;
  result.exact_modulus_mpa = material.constrained_modulus();
  result.relative_error =
      std::abs(result.fem_modulus_mpa - result.exact_modulus_mpa) / result.exact_modulus_mpa;
  return result;
}

void PointLoadOptions::Validate() const {
  ElasticMaterial{1.0, poisson_ratio}.Validate();
  if (!(patch_half_width_mm > 0.0)) throw Error("PointLoadOptions.patch_half_width_mm must be > 0");
  if (!(finest_element_mm > 0.0 && finest_element_mm <= patch_half_width_mm)) {
    throw Error("PointLoadOptions.finest_element_mm must be in (0, patch_half_width_mm]");
  }
  if (!(grading_ratio >= 1.0 && grading_ratio <= 2.0)) {
    throw Error("PointLoadOptions.grading_ratio must be in [1, 2]");
  }
  double farthest = 0.0;
  for (double r : probe_distances_mm) {
    if (!(r > patch_half_width_mm)) {
      throw Error("PointLoadOptions.probe_distances_mm must all be > patch_half_width_mm");
    }
    farthest = std::max(farthest, r);
  }
  if (!(block_size_mm >= 10.0 * farthest)) {
    throw Error("PointLoadOptions.block_size_mm must be >= 10 x the farthest probe distance");
  }
}

PointLoadResult RunPointLoad(const PointLoadOptions& options) {
  options.Validate();
  const double size = options.block_size_mm;
  const std::vector<double> plane = FineThenGraded(
      options.finest_element_mm, options.patch_half_width_mm, size, options.grading_ratio);
  std::vector<double> depth = FineThenGraded(
      options.finest_element_mm, options.patch_half_width_mm, size, options.grading_ratio);
  // Depth coordinates run from -size (base) to 0 (the loaded surface).
  std::reverse(depth.begin(), depth.end());
  for (double& z : depth) z = -z;
  const HexMesh mesh = BuildBoxMesh(plane, plane, depth);
  const int nx = static_cast<int>(plane.size()) - 1;
  const int nz = static_cast<int>(depth.size()) - 1;

  // Symmetry planes: x = 0 and y = 0. A normal load is symmetric about both; a load along x
  // is symmetric about y = 0 and antisymmetric about x = 0 (u_y = u_z = 0 there).
  std::vector<bool> fixed(mesh.num_dofs(), false);
  for (int node = 0; node < mesh.num_nodes(); ++node) {
    const Eigen::Vector3d& p = mesh.nodes[node];
    if (p.z() < -size + 1e-9) {
      for (int c = 0; c < 3; ++c) fixed[3 * node + c] = true;
    }
    if (p.y() < 1e-9) fixed[3 * node + 1] = true;
    if (p.x() < 1e-9) {
      if (options.tangential) {
        fixed[3 * node + 1] = fixed[3 * node + 2] = true;
      } else {
        fixed[3 * node + 0] = true;
      }
    }
  }
  const ElasticMaterial material{1.0, options.poisson_ratio};
  const ElasticSolver solver(mesh, material, fixed);

  // The quarter [0, a]^2 of the loaded square carries a quarter of the force.
  const double a = options.patch_half_width_mm;
  const Eigen::Vector3d force =
      options.tangential ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 0, -1);
  const Eigen::Vector3d traction = force / (4.0 * a * a);
  std::vector<int> loaded;
  for (int e : TopLayer(nx, nx, nz)) {
    const Eigen::Vector3d centre = mesh.ElementNodes(e).colwise().mean();
    if (centre.x() < a && centre.y() < a) loaded.push_back(e);
  }
  const Eigen::VectorXd u = solver.Solve(TopTractionLoads(mesh, loaded, traction));

  PointLoadResult result;
  result.num_free_dofs = solver.summary().num_free_dofs;
  const PointLocator locator(mesh);
  for (double r : options.probe_distances_mm) {
    for (double angle_deg : {0.0, 45.0, 90.0}) {
      const double angle = angle_deg * std::numbers::pi / 180.0;
      PointLoadProbe probe;
      probe.position_mm = r * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      const std::optional<ElementPoint> at =
          locator.Locate(Eigen::Vector3d(probe.position_mm.x(), probe.position_mm.y(), 0.0));
      TAC3D_DEMAND(at.has_value());
      probe.fem_mm = CalcInterpolationMatrix(mesh, {*at}) * u;
      probe.exact_mm = CalcHalfSpaceSurfaceDisplacement(force, material, probe.position_mm);
      probe.relative_error = (probe.fem_mm - probe.exact_mm).norm() / probe.exact_mm.norm();
      result.max_relative_error = std::max(result.max_relative_error, probe.relative_error);
      result.probes.push_back(probe);
    }
  }
  return result;
}

MeshConvergenceResult RunMeshConvergence(const BodyModelOptions& options,
                                         double refinement,
                                         const std::string& cache_dir,
                                         bool show_progress) {
  BodyModelOptions fine_options = options;
  fine_options.refinement = options.refinement * refinement;
  fine_options.Validate();
  const auto build = [&](const BodyModelOptions& o) {
    return cache_dir.empty() ? CalcComplianceModel(o, show_progress)
                             : LoadOrBuildComplianceModel(o, cache_dir, show_progress).model;
  };
  const ComplianceModel coarse = build(options);
  const ComplianceModel fine = build(fine_options);
  MeshConvergenceResult result;
  result.relative_difference = (coarse.h - fine.h).norm() / fine.h.norm();
  result.coarse_free_dofs = coarse.provenance.num_free_dofs;
  result.fine_free_dofs = fine.provenance.num_free_dofs;
  result.coarse_build_s = coarse.provenance.build_s;
  result.fine_build_s = fine.provenance.build_s;
  return result;
}

void EvalFemOptions::Validate() const {
  body.Validate();
  if (!(convergence_refinement == 0.0 || convergence_refinement > 1.0)) {
    throw Error(fmt::format("EvalFemOptions.convergence_refinement must be 0 or > 1, got {}",
                            convergence_refinement));
  }
}

std::string EvalFemResult::Report() const {
  std::string text = FormatChecks(checks);
  return text + fmt::format("model: {}\nall pass: {}\n", model.dump(), all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const EvalFemResult& result) {
  nlohmann::json checks = nlohmann::json::array();
  for (const EvalCheck& check : result.checks) {
    nlohmann::json json = ToJson(check);
    if (result.details.contains(check.name)) json.update(result.details.at(check.name));
    checks.push_back(std::move(json));
  }
  return {{"checks", checks}, {"model", result.model}, {"all_pass", result.all_pass}};
}

EvalFemResult EvaluateFem(const EvalFemOptions& options) {
  options.Validate();
  EvalFemResult result;
  result.details = nlohmann::json::object();
  const auto add = [&](EvalCheck check, nlohmann::json details = nlohmann::json()) {
    Report(options, check);
    if (!details.is_null()) result.details[check.name] = std::move(details);
    result.checks.push_back(std::move(check));
  };

  for (double nu : {0.3, 0.4999}) {
    const PatchTestResult patch = RunPatchTest({.poisson_ratio = nu});
    add(EvalCheck::AtMost(fmt::format("patch test nu={} interior displacement (mm)", nu),
                          patch.max_displacement_error_mm,
                          kPatchDisplacementTolerance));
    add(EvalCheck::AtMost(fmt::format("patch test nu={} stress (relative)", nu),
                          patch.max_relative_stress_error,
                          kPatchStressTolerance));
  }
  for (double nu : {0.3, 0.48, 0.499}) {
    const ConfinedBlockResult block = RunConfinedBlock(nu);
    add(EvalCheck::AtMost(fmt::format("confined block nu={} modulus", nu), block.relative_error,
                          kConfinedTolerance),
        {{"fem_modulus_mpa", block.fem_modulus_mpa},
         {"exact_modulus_mpa", block.exact_modulus_mpa}});
  }
  for (double nu : {0.3, 0.48}) {
    for (bool tangential : {false, true}) {
      const PointLoadResult load = RunPointLoad({.poisson_ratio = nu, .tangential = tangential});
      add(EvalCheck::AtMost(
              fmt::format("{} point load nu={} (3-8 mm)", tangential ? "Cerruti" : "Boussinesq", nu),
              load.max_relative_error,
              kPointLoadTolerance),
          {{"num_free_dofs", load.num_free_dofs}});
    }
  }

  if (!options.cache_dir.empty()) {
    const ComplianceCacheResult cached =
        LoadOrBuildComplianceModel(options.body, options.cache_dir, options.show_progress);
    result.model = {{"path", cached.path},
                    {"loaded_from_cache", cached.status == ComplianceCacheStatus::kLoaded},
                    {"elapsed_s", cached.elapsed_s},
                    {"provenance", ToJson(cached.model.provenance)}};
  } else {
    const ComplianceModel built = CalcComplianceModel(options.body, options.show_progress);
    result.model = {{"provenance", ToJson(built.provenance)}};
  }
  if (options.convergence_refinement > 0.0) {
    const MeshConvergenceResult convergence = RunMeshConvergence(
        options.body, options.convergence_refinement, options.cache_dir, options.show_progress);
    add(EvalCheck::AtMost(fmt::format("H change on {}x refinement (relative Frobenius)",
                                      options.convergence_refinement),
                          convergence.relative_difference,
                          kConvergenceTolerance),
        {{"coarse_free_dofs", convergence.coarse_free_dofs},
         {"fine_free_dofs", convergence.fine_free_dofs},
         {"coarse_build_s", convergence.coarse_build_s},
         {"fine_build_s", convergence.fine_build_s}});
  }
  result.all_pass = AllPass(result.checks);
  return result;
}

}  // namespace tac3d::fem
