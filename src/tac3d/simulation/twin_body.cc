#include "tac3d/simulation/twin_body.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "tac3d/util/cache_file.h"
#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"
#include "tac3d/util/shared_cache.h"
#include "tac3d/vendor_formats/vendor_gel.h"

namespace tac3d::simulation {
namespace {

// Bump whenever a change here changes the kernel or the response: part of the cache key.
constexpr int kTwinModelRevision = 1;
constexpr char kMagic[] = "TAC3DTWN";
constexpr std::uint32_t kFormatVersion = 1;

using Clock = std::chrono::steady_clock;

void Require(bool ok, const char* field, const char* bound, double value) {
  if (!ok) throw Error(fmt::format("TwinBodyOptions.{} must be {}, got {}", field, bound, value));
}

std::string TwinCodeVersion() {
  return fmt::format("{}, twin body r{}", fem::FemCodeVersion(), kTwinModelRevision);
}

// Height of the outer sphere above the base at (x, y) from the axis (mm).
double SurfaceZ(const fem::BodyModelOptions& body, double x, double y) {
  const double r = body.sphere_radius_mm;
  return body.sphere_center_z_mm() + std::sqrt(r * r - x * x - y * y);
}

// The surface point (sensor frame) at (x, y) from the axis, `depth` under the sphere along z.
Eigen::Vector3d SurfacePoint(const fem::BodyModelOptions& body, double x, double y, double depth) {
  return body.base_center_mm + Eigen::Vector3d(x, y, SurfaceZ(body, x, y) - depth);
}

// The cell-averaging operator: rows c * n + i average rows c * (q^2 n) + i q^2 + s, s < q^2,
// of an interpolation at the cells' sub-points (SubPoints' order).
Eigen::SparseMatrix<double> CellAverage(int n, int q) {
  const int per_cell = q * q;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(3 * n * per_cell);
  for (int c = 0; c < 3; ++c) {
    for (int i = 0; i < n; ++i) {
      for (int s = 0; s < per_cell; ++s) {
        t.emplace_back(c * n + i, c * n * per_cell + i * per_cell + s, 1.0 / per_cell);
      }
    }
  }
  Eigen::SparseMatrix<double> a(3 * n, 3 * n * per_cell);
  a.setFromTriplets(t.begin(), t.end());
  return a;
}

// The q x q sub-cell centres of each listed cell centre (xy), as surface points.
std::vector<Eigen::Vector3d> SubPoints(const fem::BodyModelOptions& body,
                                       const TwinBodyOptions& options,
                                       const contact::SurfaceGrid& grid,
                                       const std::vector<Eigen::Vector2d>& centres) {
  const int q = options.quadrature_points_per_side;
  std::vector<Eigen::Vector3d> points;
  points.reserve(centres.size() * q * q);
  for (const Eigen::Vector2d& centre : centres) {
    for (int b = 0; b < q; ++b) {
      for (int a = 0; a < q; ++a) {
        const double x = centre.x() + ((a + 0.5) / q - 0.5) * grid.dx_mm;
        const double y = centre.y() + ((b + 0.5) / q - 0.5) * grid.dy_mm;
        points.push_back(SurfacePoint(body, x, y, options.surface_depth_mm));
      }
    }
  }
  return points;
}

int CountFreeDofs(const fem::DomeMesh& dome) {
  int free = 0;
  for (const bool fixed : dome.fixed) free += fixed ? 0 : 1;
  return free;
}

TwinBodyOptions TwinBodyOptionsFromJson(const nlohmann::json& j) {
  TwinBodyOptions o;
  o.cells_per_pitch = j.at("cells_per_pitch").get<int>();
  o.margin_mm = j.at("margin_mm").get<double>();
  o.active_radius_fraction = j.at("active_radius_fraction").get<double>();
  o.quadrature_points_per_side = j.at("quadrature_points_per_side").get<int>();
  o.surface_depth_mm = j.at("surface_depth_mm").get<double>();
  o.kernel_radius_fraction = j.at("kernel_radius_fraction").get<double>();
  o.clamp_floor = j.at("clamp_floor").get<double>();
  o.max_direct_free_dofs = j.at("max_direct_free_dofs").get<int>();
  return o;
}

TwinBodyProvenance ProvenanceFromJson(const nlohmann::json& j) {
  TwinBodyProvenance p;
  p.num_free_dofs = j.at("num_free_dofs").get<int>();
  p.num_nodes = j.at("num_nodes").get<int>();
  p.num_elements = j.at("num_elements").get<int>();
  p.mesh_s = j.at("mesh_s").get<double>();
  p.factorization_s = j.at("factorization_s").get<double>();
  p.kernel_s = j.at("kernel_s").get<double>();
  p.response_s = j.at("response_s").get<double>();
  p.build_s = j.at("build_s").get<double>();
  p.kernel_points = j.at("kernel_points").get<int>();
  p.kernel_truncation_ratio = j.at("kernel_truncation_ratio").get<double>();
  p.kernel_asymmetry = j.at("kernel_asymmetry").get<double>();
  p.built_utc = j.at("built_utc").get<std::string>();
  p.code_version = j.at("code_version").get<std::string>();
  return p;
}

}  // namespace

void TwinBodyOptions::Validate() const {
  Require(cells_per_pitch >= 1 && cells_per_pitch <= 10,
          "cells_per_pitch",
          "in [1, 10]",
          cells_per_pitch);
  Require(margin_mm >= 0.0 && std::isfinite(margin_mm), "margin_mm", ">= 0", margin_mm);
  Require(active_radius_fraction > 0.0 && active_radius_fraction <= 1.0,
          "active_radius_fraction",
          "in (0, 1]",
          active_radius_fraction);
  Require(kernel_radius_fraction > 0.0 && kernel_radius_fraction <= 1.0,
          "kernel_radius_fraction",
          "in (0, 1]",
          kernel_radius_fraction);
  Require(quadrature_points_per_side >= 1 && quadrature_points_per_side <= 8,
          "quadrature_points_per_side",
          "in [1, 8]",
          quadrature_points_per_side);
  Require(surface_depth_mm >= 0.0 && surface_depth_mm <= 0.1,
          "surface_depth_mm",
          "in [0, 0.1]",
          surface_depth_mm);
  Require(clamp_floor >= 0.0 && clamp_floor <= 1e-3, "clamp_floor", "in [0, 1e-3]", clamp_floor);
  Require(max_direct_free_dofs >= 1, "max_direct_free_dofs", ">= 1", max_direct_free_dofs);
}

nlohmann::json ToJson(const contact::SurfaceGrid& grid) {
  return {{"nx", grid.nx}, {"ny", grid.ny}, {"dx_mm", grid.dx_mm}, {"dy_mm", grid.dy_mm}};
}

nlohmann::json ToJson(const TwinBodyOptions& o) {
  return {{"cells_per_pitch", o.cells_per_pitch},
          {"margin_mm", o.margin_mm},
          {"active_radius_fraction", o.active_radius_fraction},
          {"quadrature_points_per_side", o.quadrature_points_per_side},
          {"surface_depth_mm", o.surface_depth_mm},
          {"kernel_radius_fraction", o.kernel_radius_fraction},
          {"clamp_floor", o.clamp_floor},
          {"max_direct_free_dofs", o.max_direct_free_dofs}};
}

nlohmann::json ToJson(const TwinBodyProvenance& p) {
  return {{"num_free_dofs", p.num_free_dofs},
          {"num_nodes", p.num_nodes},
          {"num_elements", p.num_elements},
          {"mesh_s", p.mesh_s},
          {"factorization_s", p.factorization_s},
          {"kernel_s", p.kernel_s},
          {"response_s", p.response_s},
          {"build_s", p.build_s},
          {"kernel_points", p.kernel_points},
          {"kernel_truncation_ratio", p.kernel_truncation_ratio},
          {"kernel_asymmetry", p.kernel_asymmetry},
          {"built_utc", p.built_utc},
          {"code_version", p.code_version}};
}

fem::BodyModelOptions TwinBodyModelOptions(const SensorConfig& sensor,
                                           const TwinDeviation& deviation) {
  fem::BodyModelOptions body = SensorBodyModelOptions(sensor);
  body.refinement *= deviation.mesh_refinement;
  body.material.youngs_modulus_mpa *= deviation.youngs_modulus_factor;
  body.material.poisson_ratio *= deviation.poisson_ratio_factor;
  return body;
}

contact::SurfaceGrid MakeTwinContactGrid(const fem::BodyModelOptions& body,
                                         const TwinBodyOptions& options) {
  body.Validate();
  options.Validate();
  contact::SurfaceGrid grid;
  grid.dx_mm = grid.dy_mm = body.marker_pitch_mm / options.cells_per_pitch;
  // A tiny allowance so a margin of exactly k cells is k cells, not k + 1.
  const int margin = static_cast<int>(std::ceil(options.margin_mm / grid.dx_mm - 1e-9));
  grid.nx = body.marker_cols * options.cells_per_pitch + 2 * margin;
  grid.ny = body.marker_rows * options.cells_per_pitch + 2 * margin;
  grid.Validate();
  return grid;
}

std::vector<Eigen::Vector3d> TwinBodyModel::CalcNodeSurfacePoints() const {
  std::vector<Eigen::Vector3d> points(grid.num_nodes());
  const std::vector<bool> active = CalcActiveNodes();
  for (int i = 0; i < grid.num_nodes(); ++i) {
    const Eigen::Vector2d xy = grid.node_position_mm(i);
    // Inactive nodes may lie beyond the sphere's rim; they keep z = 0 and never touch.
    points[i] = active[i] ? SurfacePoint(body, xy.x(), xy.y(), 0.0)
                          : Eigen::Vector3d(body.base_center_mm + Eigen::Vector3d(xy.x(), xy.y(), 0.0));
  }
  return points;
}

std::vector<bool> TwinBodyModel::CalcActiveNodes() const {
  std::vector<bool> active(grid.num_nodes());
  const double limit = options.active_radius_fraction * body.base_radius_mm();
  for (int i = 0; i < grid.num_nodes(); ++i) active[i] = grid.node_position_mm(i).norm() <= limit;
  return active;
}

std::vector<int> TwinBodyModel::CalcNodeMarkers() const {
  std::vector<int> markers(grid.num_nodes(), -1);
  if (!body.marker_positions_mm.empty()) {
    // Markers where they were measured: the nearest one in (x, y), if its patch holds the node.
    const double half_pitch = 0.5 * body.marker_pitch_mm;
    for (int i = 0; i < grid.num_nodes(); ++i) {
      const Eigen::Vector2d xy = grid.node_position_mm(i) + body.base_center_mm.head<2>();
      double nearest = std::numeric_limits<double>::infinity();
      for (int m = 0; m < body.num_markers(); ++m) {
        const Eigen::Vector2d offset = marker_positions[m].head<2>() - xy;
        if (offset.squaredNorm() < nearest) {
          nearest = offset.squaredNorm();
          markers[i] = offset.cwiseAbs().maxCoeff() <= half_pitch ? m : -1;
        }
      }
    }
    return markers;
  }
  const int cpp = options.cells_per_pitch;
  const int margin_x = (grid.nx - body.marker_cols * cpp) / 2;
  const int margin_y = (grid.ny - body.marker_rows * cpp) / 2;
  for (int j = 0; j < grid.ny; ++j) {
    for (int i = 0; i < grid.nx; ++i) {
      const int a = i - margin_x, b = j - margin_y;
      if (a < 0 || b < 0 || a >= body.marker_cols * cpp || b >= body.marker_rows * cpp) continue;
      markers[j * grid.nx + i] = (b / cpp) * body.marker_cols + a / cpp;
    }
  }
  return markers;
}

namespace {

// Refuses a body whose mesh is too large for the direct factorisation the simulation needs.
void RequireDirectFactorisation(const fem::BodyModelOptions& body, const TwinBodyOptions& options) {
  const fem::DomeMesh dome = fem::BuildDomeMesh(body);
  const int free = CountFreeDofs(dome);
  if (free > options.max_direct_free_dofs) {
    throw Error(fmt::format(
        "the twin body at refinement {} has {} free DOFs, more than the {} a direct "
        "factorisation handles (TwinBodyOptions.max_direct_free_dofs); the iterative solver "
        "would take hours for the simulation's {} solves: use deviation.mesh_refinement <= 1.5",
        body.refinement,
        free,
        options.max_direct_free_dofs,
        3 * body.num_markers() + 3));
  }
}

// The kernel as sampled: the displacements at every lattice offset (di, dj) from the centre
// node under unit cell tractions there, in the ComplianceOperator's signs.
struct KernelSamples {
  contact::SampledKernel raw;
  std::vector<Eigen::Vector2i> offsets;              // (di, dj) of each sampled point
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // the centre node (mm)
  double radius_limit_mm = 0.0;                      // no sample beyond this radius
};

// Unit cell tractions at the centre node, displacements at every offset point.
KernelSamples SampleKernel(const fem::BodyModel& fem_model,
                           const fem::BodyModelOptions& body,
                           const TwinBodyOptions& options,
                           const contact::SurfaceGrid& grid) {
  KernelSamples samples;
  const int ci = grid.nx / 2, cj = grid.ny / 2;
  samples.centre = grid.node_position_mm(cj * grid.nx + ci);
  const Eigen::Vector2d& centre = samples.centre;
  const Eigen::SparseMatrix<double> source =
      CellAverage(1, options.quadrature_points_per_side) *
      fem_model.CalcPointInterpolation(SubPoints(body, options, grid, {centre}));
  samples.radius_limit_mm = options.kernel_radius_fraction * body.base_radius_mm();
  // Near the rim the mesh's faceted surface may dip below surface_depth_mm: points the mesh
  // does not hold are left out (zero kernel), like those beyond the radius.
  const fem::PointLocator locator(fem_model.mesh());
  std::vector<Eigen::Vector3d> lattice;
  std::vector<Eigen::Vector2i>& offsets = samples.offsets;
  for (int dj = -(grid.ny - 1); dj < grid.ny; ++dj) {
    for (int di = -(grid.nx - 1); di < grid.nx; ++di) {
      const Eigen::Vector2d xy = centre + Eigen::Vector2d(di * grid.dx_mm, dj * grid.dy_mm);
      if (xy.norm() > samples.radius_limit_mm) continue;
      const Eigen::Vector3d point = SurfacePoint(body, xy.x(), xy.y(), options.surface_depth_mm);
      if (!locator.Locate(point)) continue;
      lattice.push_back(point);
      offsets.emplace_back(di, dj);
    }
  }
  // u (3 P x 3), mm/N; rows c * P + p.
  const Eigen::MatrixXd u = fem_model.solver().CalcResponse(
      fem_model.CalcPointInterpolation(lattice), source.transpose(), false);
  // ComplianceOperator's signs: the normal component is -z for both traction and displacement.
  const double sign[3] = {1.0, 1.0, -1.0};
  const double area = grid.cell_area_mm2();
  samples.raw = contact::SampledKernel::Zero(grid);
  const int num_points = static_cast<int>(offsets.size());
  for (int k = 0; k < num_points; ++k) {
    for (int out = 0; out < 3; ++out) {
      for (int in = 0; in < 3; ++in) {
        samples.raw.at(out, in, offsets[k].x(), offsets[k].y()) =
            sign[out] * sign[in] * area * u(out * num_points + k, in);
      }
    }
  }
  return samples;
}

// Reciprocity: K_ab(d) := (K_ab(d) + K_ba(-d)) / 2, with the raw kernel's largest entry and
// largest departure from reciprocity.
struct ReciprocalKernel {
  contact::SampledKernel kernel;
  double largest = 0.0;
  double asymmetry = 0.0;
};

ReciprocalKernel MakeReciprocal(const contact::SampledKernel& raw) {
  ReciprocalKernel r;
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      const Eigen::MatrixXd mirrored = raw.k[in][out].reverse();
      r.kernel.k[out][in] = 0.5 * (raw.k[out][in] + mirrored);
      r.largest = std::max(r.largest, raw.k[out][in].cwiseAbs().maxCoeff());
      r.asymmetry = std::max(r.asymmetry, (raw.k[out][in] - mirrored).cwiseAbs().maxCoeff());
    }
  }
  return r;
}

// Decay: the largest entry at the outermost sampled ring (within one cell of the limit).
double LargestAtOuterRing(const contact::SampledKernel& kernel,
                          const KernelSamples& samples,
                          const contact::SurfaceGrid& grid) {
  double boundary = 0.0;
  for (const Eigen::Vector2i& d : samples.offsets) {
    const Eigen::Vector2d xy =
        samples.centre + Eigen::Vector2d(d.x() * grid.dx_mm, d.y() * grid.dy_mm);
    if (xy.norm() < samples.radius_limit_mm - grid.dx_mm) continue;
    for (int out = 0; out < 3; ++out) {
      for (int in = 0; in < 3; ++in) {
        boundary = std::max(boundary, std::abs(kernel.at(out, in, d.x(), d.y())));
      }
    }
  }
  return boundary;
}

// Marker response by reciprocity: M^T = L^T K^-1 P^T, L the active cells' uniform loads;
// (3 markers x 3 nodes), zero in the columns of inactive nodes.
Eigen::MatrixXd CalcMarkerResponse(const TwinBodyModel& model,
                                   const fem::BodyModel& fem_model,
                                   bool show_progress) {
  const contact::SurfaceGrid& grid = model.grid;
  const int n = grid.num_nodes();
  const std::vector<bool> active = model.CalcActiveNodes();
  std::vector<Eigen::Vector2d> cells;
  std::vector<int> cell_nodes;
  for (int i = 0; i < n; ++i) {
    if (!active[i]) continue;
    cells.push_back(grid.node_position_mm(i));
    cell_nodes.push_back(i);
  }
  const int m = static_cast<int>(cells.size());
  const Eigen::SparseMatrix<double> cell_readout =
      CellAverage(m, model.options.quadrature_points_per_side) *
      fem_model.CalcPointInterpolation(SubPoints(model.body, model.options, grid, cells));
  const Eigen::SparseMatrix<double> marker_loads =
      fem_model.CalcPointInterpolation(model.marker_positions).transpose();
  const Eigen::MatrixXd response_t =
      fem_model.solver().CalcResponse(cell_readout, marker_loads, show_progress);  // 3m x 3N
  const int num_markers = static_cast<int>(model.marker_positions.size());
  Eigen::MatrixXd response = Eigen::MatrixXd::Zero(3 * num_markers, 3 * n);
  for (int c = 0; c < 3; ++c) {
    for (int k = 0; k < m; ++k) {
      response.col(c * n + cell_nodes[k]) = response_t.row(c * m + k).transpose();
    }
  }
  return response;
}

}  // namespace

TwinBodyModel CalcTwinBodyModel(const fem::BodyModelOptions& body,
                                const TwinBodyOptions& options,
                                bool show_progress) {
  const auto start = Clock::now();
  TwinBodyModel model;
  model.body = body;
  model.options = options;
  model.grid = MakeTwinContactGrid(body, options);
  RequireDirectFactorisation(body, options);
  fem::BodySolverOptions solver_options;
  solver_options.max_direct_free_dofs = options.max_direct_free_dofs;
  const auto mesh_start = Clock::now();
  const fem::BodyModel fem_model(body, show_progress, solver_options);
  TAC3D_DEMAND(fem_model.solver().summary().method == fem::ElasticSolverMethod::kDirect);
  TwinBodyProvenance& p = model.provenance;
  p.num_free_dofs = fem_model.solver().summary().num_free_dofs;
  p.num_nodes = fem_model.mesh().num_nodes();
  p.num_elements = fem_model.mesh().num_elements();
  p.factorization_s =
      fem_model.solver().summary().assembly_s + fem_model.solver().summary().factorization_s;
  p.mesh_s = SecondsSince(mesh_start) - p.factorization_s;
  model.marker_positions = fem_model.marker_positions();

  const auto kernel_start = Clock::now();
  const KernelSamples samples = SampleKernel(fem_model, body, options, model.grid);
  p.kernel_points = static_cast<int>(samples.offsets.size());
  ReciprocalKernel reciprocal = MakeReciprocal(samples.raw);
  model.kernel = std::move(reciprocal.kernel);
  p.kernel_asymmetry = reciprocal.asymmetry / reciprocal.largest;
  p.kernel_truncation_ratio =
      LargestAtOuterRing(model.kernel, samples, model.grid) / reciprocal.largest;
  p.kernel_s = SecondsSince(kernel_start);

  const auto response_start = Clock::now();
  model.marker_response = SharedMatrix(CalcMarkerResponse(model, fem_model, show_progress));
  p.response_s = SecondsSince(response_start);
  p.build_s = SecondsSince(start);
  p.built_utc = UtcNow();
  p.code_version = TwinCodeVersion();
  return model;
}

std::uint64_t CalcTwinBodyCacheKey(const fem::BodyModelOptions& body,
                                   const TwinBodyOptions& options) {
  // nlohmann::json orders keys, so the dump is canonical; doubles print round-trip exact.
  const std::string text =
      fem::ToJson(body).dump() + "|" + ToJson(options).dump() + "|" + TwinCodeVersion();
  return Fnv1a(text.data(), text.size());
}

SharedMatrix::SharedMatrix(Eigen::MatrixXd owned) {
  auto storage = std::make_shared<const Eigen::MatrixXd>(std::move(owned));
  data_ = storage->data();
  rows_ = storage->rows();
  cols_ = storage->cols();
  storage_ = std::move(storage);
}

SharedMatrix::SharedMatrix(const MappedMatrix& mapped, std::shared_ptr<const void> mapping)
    : storage_(std::move(mapping)),
      data_(mapped.data),
      rows_(mapped.rows),
      cols_(mapped.cols),
      mapped_(true) {}

void SaveTwinBodyModel(const TwinBodyModel& model, const std::string& path) {
  CacheRecord record;
  record.key = CalcTwinBodyCacheKey(model.body, model.options);
  record.header = {{"body", fem::ToJson(model.body)},
                   {"options", ToJson(model.options)},
                   {"grid", ToJson(model.grid)},
                   {"provenance", ToJson(model.provenance)}};
  for (const auto& row : model.kernel.k) {
    for (const Eigen::MatrixXd& k : row) record.matrices.push_back(k);
  }
  record.matrices.push_back(model.marker_response.view());
  WriteCacheRecord(path, kMagic, kFormatVersion, record);
}

namespace {

struct CachedModel {
  std::uint64_t key = 0;
  TwinBodyModel model;
};

// Maps and checks a file's structure; the key is returned, not judged.
CachedModel ReadTwinBodyFile(const std::string& path) {
  MappedCacheRecord record = MapCacheRecord(path, kMagic, kFormatVersion);
  CachedModel cached;
  cached.key = record.key;
  TwinBodyModel& model = cached.model;
  try {
    model.body = fem::BodyModelOptionsFromJson(record.header.at("body"));
    model.options = TwinBodyOptionsFromJson(record.header.at("options"));
    model.provenance = ProvenanceFromJson(record.header.at("provenance"));
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: invalid JSON header: {}", path, e.what()));
  }
  model.grid = MakeTwinContactGrid(model.body, model.options);
  const contact::SampledKernel zero = contact::SampledKernel::Zero(model.grid);
  const int num_markers = model.body.num_markers();
  if (record.matrices.size() != 10) {
    throw Error(fmt::format("{}: {} matrices, expected 10", path, record.matrices.size()));
  }
  for (int k = 0; k < 9; ++k) {
    const MappedMatrix& m = record.matrices[k];
    if (m.rows != zero.k[0][0].rows() || m.cols != zero.k[0][0].cols()) {
      throw Error(fmt::format("{}: kernel {} has the wrong size", path, k));
    }
    // Small (the grid's size): copied, so the FFTs read aligned memory.
    model.kernel.k[k / 3][k % 3] = Eigen::Map<const Eigen::MatrixXd>(m.data, m.rows, m.cols);
  }
  model.marker_response = SharedMatrix(record.matrices[9], record.mapping);
  if (model.marker_response.rows() != 3 * num_markers ||
      model.marker_response.cols() != 3 * model.grid.num_nodes()) {
    throw Error(fmt::format("{}: the marker response has the wrong size", path));
  }
  model.marker_positions = fem::CalcMarkerPositions(model.body);
  return cached;
}

}  // namespace

TwinBodyModel LoadTwinBodyModel(const std::string& path) {
  CachedModel cached = ReadTwinBodyFile(path);
  if (cached.key != CalcTwinBodyCacheKey(cached.model.body, cached.model.options)) {
    throw Error(fmt::format("{}: key {:016x} does not match its inputs and this code ({})",
                            path,
                            cached.key,
                            TwinCodeVersion()));
  }
  return std::move(cached.model);
}

TwinBodyCacheResult LoadOrBuildTwinBodyModel(const fem::BodyModelOptions& body,
                                             const TwinBodyOptions& options,
                                             const std::string& cache_dir,
                                             bool show_progress) {
  body.Validate();
  options.Validate();
  const auto start = Clock::now();
  const std::uint64_t key = CalcTwinBodyCacheKey(body, options);
  TwinBodyCacheResult result;
  result.path = CacheFilePath(cache_dir, "twin_body", key);
  result.status = LoadOrBuildCacheFile(
      result.path, key, ReadTwinBodyFile,
      [&] { return CalcTwinBodyModel(body, options, show_progress); }, SaveTwinBodyModel,
      &result.model, &result.reason);
  result.elapsed_s = SecondsSince(start);
  return result;
}

std::shared_ptr<const TwinBodyModel> LoadSharedTwinBodyModel(const fem::BodyModelOptions& body,
                                                             const TwinBodyOptions& options,
                                                             const std::string& cache_dir,
                                                             bool show_progress,
                                                             SharedModelSource* source) {
  body.Validate();
  options.Validate();
  // One key, one model, whichever cache_dir it comes from (as fem::LoadSharedComplianceModel).
  static SharedCache<std::uint64_t, TwinBodyModel> models;
  const std::uint64_t key = CalcTwinBodyCacheKey(body, options);
  return GetSharedModel(
      models, key, CacheFilePath(cache_dir, "twin_body", key),
      [&] { return LoadOrBuildTwinBodyModel(body, options, cache_dir, show_progress); }, source);
}

}  // namespace tac3d::simulation
