#include "tac3d/fem/body_model.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

// Elements per marker pitch under the sensing area at refinement 1 (the paper's mesh), and
// the size ratio of neighbouring elements where the mesh is graded.
constexpr double kElementsPerPitch = 3.0;
constexpr double kGradingRatio = 1.2;

// Fractions 0 = s_0 < ... < s_n = 1 of a graded direction: the mapping
// s(t) = (g^(m t) - 1) / (g^m - 1) sampled at t = k / n. m is the element count at
// refinement 1 chosen so that the first element is about first_size over length; n = m times
// the refinement, so a refined mesh samples the same mapping more densely.
std::vector<double> GradedFractions(double length, double first_size, double refinement) {
  const int m =
      std::max(1,
               static_cast<int>(std::ceil(std::log1p(length * (kGradingRatio - 1.0) / first_size) /
                                          std::log(kGradingRatio))));
  const int n = std::max(1, static_cast<int>(std::lround(m * refinement)));
  const double denominator = std::pow(kGradingRatio, m) - 1.0;
  std::vector<double> s(n + 1);
  for (int k = 0; k <= n; ++k) {
    s[k] = (std::pow(kGradingRatio, m * static_cast<double>(k) / n) - 1.0) / denominator;
  }
  return s;
}

void RequirePositive(double value, const char* field) {
  if (!(value > 0.0)) {
    throw Error(fmt::format("BodyModelOptions.{} must be > 0, got {}", field, value));
  }
}

// Half-width of the central block about the axis: the markers with their load patches.
double CentralHalfWidth(const BodyModelOptions& options) {
  if (options.marker_positions_mm.empty()) {
    return 0.5 * std::max(options.marker_rows, options.marker_cols) * options.marker_pitch_mm;
  }
  double half_width = 0.0;
  for (const Eigen::Vector3d& p : options.marker_positions_mm) {
    const Eigen::Vector2d from_axis = (p - options.base_center_mm).head<2>();
    half_width = std::max(half_width, from_axis.cwiseAbs().maxCoeff());
  }
  return half_width + 0.5 * options.marker_pitch_mm;
}

// Given marker positions: rows x cols of them, finite, inside the body.
void ValidateGivenMarkers(const BodyModelOptions& options) {
  const auto count = static_cast<int>(options.marker_positions_mm.size());
  if (count != options.num_markers()) {
    throw Error(fmt::format("BodyModelOptions.marker_positions_mm has {} positions, the {} x {} "
                            "grid needs {}",
                            count,
                            options.marker_rows,
                            options.marker_cols,
                            options.num_markers()));
  }
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector3d p = options.marker_positions_mm[k] - options.base_center_mm;
    const double r = p.head<2>().norm();
    if (!p.allFinite() || !(r <= 0.95 * options.base_radius_mm()) || !(p.z() > 0.0) ||
        !(p.z() < options.SurfaceHeight(r))) {
      throw Error(fmt::format(
          "BodyModelOptions.marker_positions_mm[{}] ({}, {}, {}) mm is not inside the body (within "
          "0.95 x the base radius of the axis, between the base and the outer surface)",
          k,
          options.marker_positions_mm[k].x(),
          options.marker_positions_mm[k].y(),
          options.marker_positions_mm[k].z()));
    }
  }
}

// Radius of the outermost marker from the axis (mm).
double OutermostMarkerRadius(const BodyModelOptions& options) {
  return 0.5 * options.marker_pitch_mm *
         std::hypot(options.marker_cols - 1.0, options.marker_rows - 1.0);
}

// A fine node may lie outside the coarse mesh by the sagitta of a coarse element's face under
// the curved surfaces (up to ~0.1 of a thin rim element); it is then extrapolated, which a
// preconditioner's interpolation tolerates.
constexpr double kProlongationTolerance = 0.25;

// P (fine num_dofs x coarse num_dofs): the coarse trilinear interpolation at the fine nodes.
Eigen::SparseMatrix<double> CalcProlongation(const HexMesh& coarse, const HexMesh& fine) {
  const PointLocator locator(coarse);
  std::vector<ElementPoint> points;
  points.reserve(fine.num_nodes());
  for (int n = 0; n < fine.num_nodes(); ++n) {
    const std::optional<ElementPoint> point = locator.Locate(fine.nodes[n], kProlongationTolerance);
    if (!point) {
      throw Error(fmt::format("BodyModel: fine node {} ({}, {}, {}) mm is in no coarse element",
                              n,
                              fine.nodes[n].x(),
                              fine.nodes[n].y(),
                              fine.nodes[n].z()));
    }
    points.push_back(*point);
  }
  // CalcInterpolationMatrix's rows are component-major (c P + p); DOFs are node-major.
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> to_dofs(fine.num_dofs());
  for (int n = 0; n < fine.num_nodes(); ++n) {
    for (int c = 0; c < 3; ++c) to_dofs.indices()(c * fine.num_nodes() + n) = 3 * n + c;
  }
  return to_dofs * CalcInterpolationMatrix(coarse, points);
}

ElasticSolver MakeSolver(const BodyModelOptions& options,
                         const DomeMesh& dome,
                         const BodySolverOptions& solver,
                         bool show_progress) {
  solver.Validate();
  const long num_free = std::count(dome.fixed.begin(), dome.fixed.end(), false);
  if (num_free <= solver.max_direct_free_dofs) {
    return ElasticSolver(dome.mesh, options.material, dome.fixed, show_progress);
  }
  BodyModelOptions coarse_options = options;
  coarse_options.refinement /= solver.coarsening_ratio;
  if (coarse_options.refinement < 0.25) {
    throw Error(fmt::format(
        "BodySolverOptions.coarsening_ratio {} gives the coarse level refinement {} < 0.25",
        solver.coarsening_ratio,
        coarse_options.refinement));
  }
  const DomeMesh coarse = BuildDomeMesh(coarse_options);
  return ElasticSolver(dome.mesh,
                       options.material,
                       dome.fixed,
                       coarse.mesh,
                       coarse.fixed,
                       CalcProlongation(coarse.mesh, dome.mesh),
                       solver.pcg,
                       show_progress);
}

}  // namespace

void BodySolverOptions::Validate() const {
  if (max_direct_free_dofs < 0) {
    throw Error(fmt::format("BodySolverOptions.max_direct_free_dofs must be >= 0, got {}",
                            max_direct_free_dofs));
  }
  if (!(coarsening_ratio > 1.0)) {
    throw Error(
        fmt::format("BodySolverOptions.coarsening_ratio must be > 1, got {}", coarsening_ratio));
  }
  pcg.Validate();
}

void BodyModelOptions::Validate() const {
  RequirePositive(base_diameter_mm, "base_diameter_mm");
  RequirePositive(thickness_mm, "thickness_mm");
  RequirePositive(sphere_radius_mm, "sphere_radius_mm");
  RequirePositive(marker_pitch_mm, "marker_pitch_mm");
  if (!(sphere_radius_mm > base_radius_mm())) {
    throw Error(
        fmt::format("BodyModelOptions.sphere_radius_mm must be > the base radius {} mm, got {}",
                    base_radius_mm(),
                    sphere_radius_mm));
  }
  const double sagitta =
      sphere_radius_mm - std::sqrt(std::pow(sphere_radius_mm, 2) - std::pow(base_radius_mm(), 2));
  if (!(thickness_mm > sagitta)) {
    throw Error(fmt::format(
        "BodyModelOptions.thickness_mm must be > {} mm (the sphere's sagitta over the base), "
        "got {}",
        sagitta,
        thickness_mm));
  }
  material.Validate();
  for (const auto& [value, field] :
       {std::pair{marker_rows, "marker_rows"}, std::pair{marker_cols, "marker_cols"}}) {
    if (value < 1 || value > 200) {
      throw Error(fmt::format("BodyModelOptions.{} must be in [1, 200], got {}", field, value));
    }
  }
  const double corner = std::numbers::sqrt2 * CentralHalfWidth(*this);
  if (!(corner <= 0.95 * base_radius_mm())) {
    throw Error(
        fmt::format("BodyModelOptions.marker_rows/marker_cols/marker_pitch_mm: the marker grid's "
                    "load patches reach {} mm from the "
                    "axis; they must stay within 0.95 x the base radius = {} mm",
                    corner,
                    0.95 * base_radius_mm()));
  }
  if (!base_center_mm.allFinite()) {
    throw Error("BodyModelOptions.base_center_mm must be finite");
  }
  const double max_depth =
      sphere_radius_mm - std::hypot(OutermostMarkerRadius(*this), sphere_center_z_mm());
  if (!marker_positions_mm.empty()) {
    ValidateGivenMarkers(*this);
  } else if (!(marker_depth_mm > 0.0 && marker_depth_mm < max_depth)) {
    throw Error(fmt::format(
        "BodyModelOptions.marker_depth_mm must be in (0, {}) mm (the body's depth at the "
        "outermost marker), got {}",
        max_depth,
        marker_depth_mm));
  }
  if (!(refinement >= 0.25 && refinement <= 4.0)) {
    throw Error(
        fmt::format("BodyModelOptions.refinement must be in [0.25, 4], got {}", refinement));
  }
}

double BodyModelOptions::SurfaceHeight(double r_mm) const {
  return sphere_center_z_mm() + std::sqrt(sphere_radius_mm * sphere_radius_mm - r_mm * r_mm);
}

BodyModelOptions BodyModelOptionsFromSensor(const SensorConfig& config) {
  const ElasticBodyConfig& body = config.elastic_body;
  BodyModelOptions options;
  options.base_diameter_mm = body.base_diameter_mm;
  options.thickness_mm = body.thickness_mm;
  options.sphere_radius_mm = body.outer_radius_mm;
  options.lateral_boundary =
      body.lateral_face == LateralFace::kFixed ? LateralBoundary::kFixed : LateralBoundary::kFree;
  options.material.youngs_modulus_mpa = body.youngs_modulus_mpa;
  options.material.poisson_ratio = body.poisson_ratio;
  options.marker_rows = config.markers.rows;
  options.marker_cols = config.markers.cols;
  options.marker_pitch_mm = config.markers.pitch_mm;
  options.marker_depth_mm = config.markers.depth_mm;
  return options;
}

nlohmann::json ToJson(const BodyModelOptions& options) {
  nlohmann::json json = {
      {"base_diameter_mm", options.base_diameter_mm},
      {"thickness_mm", options.thickness_mm},
      {"sphere_radius_mm", options.sphere_radius_mm},
      {"lateral_boundary", options.lateral_boundary == LateralBoundary::kFixed ? "fixed" : "free"},
      {"youngs_modulus_mpa", options.material.youngs_modulus_mpa},
      {"poisson_ratio", options.material.poisson_ratio},
      {"marker_rows", options.marker_rows},
      {"marker_cols", options.marker_cols},
      {"marker_pitch_mm", options.marker_pitch_mm},
      {"marker_depth_mm", options.marker_depth_mm},
      {"refinement", options.refinement},
  };
  if (!options.base_center_mm.isZero(0.0)) {
    json["base_center_mm"] = {
        options.base_center_mm.x(), options.base_center_mm.y(), options.base_center_mm.z()};
  }
  if (!options.marker_positions_mm.empty()) {
    nlohmann::json& markers = json["marker_positions_mm"] = nlohmann::json::array();
    for (const Eigen::Vector3d& p : options.marker_positions_mm) markers.push_back({p.x(), p.y(), p.z()});
  }
  return json;
}

BodyModelOptions BodyModelOptionsFromJson(const nlohmann::json& json) {
  try {
    BodyModelOptions options;
    options.base_diameter_mm = json.at("base_diameter_mm").get<double>();
    options.thickness_mm = json.at("thickness_mm").get<double>();
    options.sphere_radius_mm = json.at("sphere_radius_mm").get<double>();
    const std::string lateral = json.at("lateral_boundary").get<std::string>();
    if (lateral != "free" && lateral != "fixed") {
      throw Error(
          fmt::format("BodyModelOptions.lateral_boundary must be free or fixed, got {}", lateral));
    }
    options.lateral_boundary =
        lateral == "fixed" ? LateralBoundary::kFixed : LateralBoundary::kFree;
    options.material.youngs_modulus_mpa = json.at("youngs_modulus_mpa").get<double>();
    options.material.poisson_ratio = json.at("poisson_ratio").get<double>();
    options.marker_rows = json.at("marker_rows").get<int>();
    options.marker_cols = json.at("marker_cols").get<int>();
    options.marker_pitch_mm = json.at("marker_pitch_mm").get<double>();
    options.marker_depth_mm = json.at("marker_depth_mm").get<double>();
    options.refinement = json.at("refinement").get<double>();
    const auto point = [](const nlohmann::json& xyz) {
      const auto v = xyz.get<std::array<double, 3>>();
      return Eigen::Vector3d(v[0], v[1], v[2]);
    };
    if (json.contains("base_center_mm")) options.base_center_mm = point(json["base_center_mm"]);
    if (json.contains("marker_positions_mm")) {
      for (const nlohmann::json& p : json["marker_positions_mm"]) {
        options.marker_positions_mm.push_back(point(p));
      }
    }
    return options;
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("BodyModelOptions from JSON: {}", e.what()));
  }
}

std::vector<Eigen::Vector3d> CalcMarkerPositions(const BodyModelOptions& options) {
  options.Validate();
  if (!options.marker_positions_mm.empty()) return options.marker_positions_mm;
  const double radius = options.sphere_radius_mm - options.marker_depth_mm;
  std::vector<Eigen::Vector3d> markers;
  markers.reserve(options.num_markers());
  for (int i = 0; i < options.marker_rows; ++i) {
    for (int j = 0; j < options.marker_cols; ++j) {
      const double x = (j - 0.5 * (options.marker_cols - 1)) * options.marker_pitch_mm;
      const double y = (i - 0.5 * (options.marker_rows - 1)) * options.marker_pitch_mm;
      const double z = options.sphere_center_z_mm() + std::sqrt(radius * radius - x * x - y * y);
      markers.push_back(options.base_center_mm + Eigen::Vector3d(x, y, z));
    }
  }
  return markers;
}

int DomeMesh::CentralTopElement(int i, int j) const {
  TAC3D_DEMAND(i >= 0 && i < central_elements && j >= 0 && j < central_elements);
  const int quads = central_elements * central_elements + 4 * central_elements * ring_elements;
  return (layers - 1) * quads + j * central_elements + i;
}

DomeMesh BuildDomeMesh(const BodyModelOptions& options) {
  options.Validate();
  const double pitch_size = options.marker_pitch_mm / kElementsPerPitch;
  const double a = CentralHalfWidth(options);
  const double base_radius = options.base_radius_mm();
  const int nc =
      std::max(1, static_cast<int>(std::lround(2.0 * a / pitch_size * options.refinement)));
  // Ring and layers: the first element next to the central block (resp. the outer surface) is
  // about as large as the central block's elements.
  const std::vector<double> ring = GradedFractions(base_radius - a, pitch_size, options.refinement);
  const std::vector<double> depth =
      GradedFractions(options.thickness_mm, pitch_size, options.refinement);
  const int nr = static_cast<int>(ring.size()) - 1;
  const int nz = static_cast<int>(depth.size()) - 1;

  // The planar O-grid: central (nc + 1)^2 grid nodes, then ring nodes (q, k), k = 1..nr, on the
  // 4 nc perimeter stations q counter-clockwise from the corner (a, -a).
  std::vector<Eigen::Vector2d> planar;
  for (int j = 0; j <= nc; ++j) {
    for (int i = 0; i <= nc; ++i) {
      planar.emplace_back(-a + 2.0 * a * i / nc, -a + 2.0 * a * j / nc);
    }
  }
  const auto grid_id = [&](int i, int j) { return j * (nc + 1) + i; };
  const int num_grid = static_cast<int>(planar.size());
  const int stations = 4 * nc;
  std::vector<int> perimeter(stations);
  for (int q = 0; q < stations; ++q) {
    const int side = q / nc;
    const double t = static_cast<double>(q % nc) / nc;
    // Side 0 is x = a; the others are it turned by multiples of 90 degrees.
    const Eigen::Rotation2Dd turn(side * std::numbers::pi / 2.0);
    const Eigen::Vector2d square = turn * Eigen::Vector2d(a, -a + 2.0 * a * t);
    const double angle = -std::numbers::pi / 4.0 + std::numbers::pi / 2.0 * (side + t);
    const Eigen::Vector2d circle = base_radius * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    const int i = static_cast<int>(std::lround((square.x() + a) / (2.0 * a) * nc));
    const int j = static_cast<int>(std::lround((square.y() + a) / (2.0 * a) * nc));
    perimeter[q] = grid_id(i, j);
    for (int k = 1; k <= nr; ++k) planar.push_back(square + ring[k] * (circle - square));
  }
  const auto ring_id = [&](int q, int k) {
    q %= stations;
    return k == 0 ? perimeter[q] : num_grid + q * nr + (k - 1);
  };
  // Quads counter-clockwise seen from +z, central block first.
  std::vector<std::array<int, 4>> quads;
  for (int j = 0; j < nc; ++j) {
    for (int i = 0; i < nc; ++i) {
      quads.push_back({grid_id(i, j), grid_id(i + 1, j), grid_id(i + 1, j + 1), grid_id(i, j + 1)});
    }
  }
  for (int q = 0; q < stations; ++q) {
    for (int k = 0; k < nr; ++k) {
      quads.push_back({ring_id(q, k), ring_id(q, k + 1), ring_id(q + 1, k + 1), ring_id(q + 1, k)});
    }
  }

  DomeMesh dome;
  dome.central_half_width_mm = a;
  dome.central_elements = nc;
  dome.ring_elements = nr;
  dome.layers = nz;
  const int num_planar = static_cast<int>(planar.size());
  // Layer l = 0 is the base; node height is a fraction of the local surface height.
  for (int l = 0; l <= nz; ++l) {
    for (const Eigen::Vector2d& p : planar) {
      const double height = options.SurfaceHeight(p.norm());
      dome.mesh.nodes.push_back(options.base_center_mm +
                                Eigen::Vector3d(p.x(), p.y(), (1.0 - depth[nz - l]) * height));
    }
  }
  for (int l = 0; l < nz; ++l) {
    for (const auto& quad : quads) {
      std::array<int, 8> element;
      for (int c = 0; c < 4; ++c) {
        element[c] = l * num_planar + quad[c];
        element[c + 4] = (l + 1) * num_planar + quad[c];
      }
      dome.mesh.elements.push_back(element);
    }
  }
  const int num_quads = static_cast<int>(quads.size());
  for (int q = 0; q < num_quads; ++q)
    dome.outer_surface_elements.push_back((nz - 1) * num_quads + q);

  dome.fixed.assign(dome.mesh.num_dofs(), false);
  const auto fix_node = [&](int node) {
    for (int c = 0; c < 3; ++c) dome.fixed[3 * node + c] = true;
  };
  for (int p = 0; p < num_planar; ++p) fix_node(p);
  if (options.lateral_boundary == LateralBoundary::kFixed) {
    for (int l = 1; l <= nz; ++l) {
      for (int q = 0; q < stations; ++q) fix_node(l * num_planar + ring_id(q, nr));
    }
  }
  TAC3D_DEMAND(CalcMinJacobianDeterminant(dome.mesh) > 0.0);
  return dome;
}

BodyModel::BodyModel(const BodyModelOptions& options,
                     bool show_progress,
                     const BodySolverOptions& solver)
    : options_(options),
      dome_(BuildDomeMesh(options)),
      solver_(MakeSolver(options, dome_, solver, show_progress)),
      locator_(dome_.mesh),
      marker_positions_(CalcMarkerPositions(options)) {}

Eigen::SparseMatrix<double> BodyModel::CalcMarkerPatchLoads() const {
  const int num_markers = options_.num_markers();
  const double a = dome_.central_half_width_mm;
  const int nc = dome_.central_elements;
  const double h = 2.0 * a / nc;
  const double half_pitch = 0.5 * options_.marker_pitch_mm;
  // Overlaps thinner than this (in units of an element) are rounding at coinciding edges.
  constexpr double kMinOverlap = 1e-9;

  std::vector<Eigen::Triplet<double>> triplets;
  for (int k = 0; k < num_markers; ++k) {
    // The central block's cells are about the axis.
    const Eigen::Vector3d marker = marker_positions_[k] - options_.base_center_mm;
    const double x0 = marker.x() - half_pitch, x1 = marker.x() + half_pitch;
    const double y0 = marker.y() - half_pitch, y1 = marker.y() + half_pitch;
    // The central block's outer-surface elements under the patch, and the part of each.
    struct Piece {
      int element;
      TopFaceIntegrals integrals;
    };
    std::vector<Piece> pieces;
    double area = 0.0;
    const int i_begin = std::max(0, static_cast<int>(std::floor((x0 + a) / h)));
    const int i_end = std::min(nc, static_cast<int>(std::ceil((x1 + a) / h)));
    const int j_begin = std::max(0, static_cast<int>(std::floor((y0 + a) / h)));
    const int j_end = std::min(nc, static_cast<int>(std::ceil((y1 + a) / h)));
    for (int j = j_begin; j < j_end; ++j) {
      for (int i = i_begin; i < i_end; ++i) {
        const double cell_x = -a + i * h, cell_y = -a + j * h;
        const double xi0 = std::max(-1.0, 2.0 * (x0 - cell_x) / h - 1.0);
        const double xi1 = std::min(1.0, 2.0 * (x1 - cell_x) / h - 1.0);
        const double eta0 = std::max(-1.0, 2.0 * (y0 - cell_y) / h - 1.0);
        const double eta1 = std::min(1.0, 2.0 * (y1 - cell_y) / h - 1.0);
        if (xi1 - xi0 < kMinOverlap || eta1 - eta0 < kMinOverlap) continue;
        const int element = dome_.CentralTopElement(i, j);
        pieces.push_back(
            {element, IntegrateHex8TopFace(mesh().ElementNodes(element), xi0, xi1, eta0, eta1)});
        area += pieces.back().integrals.area_mm2;
      }
    }
    TAC3D_DEMAND(area > 0.0);
    for (const Piece& piece : pieces) {
      for (int a_local = 0; a_local < 4; ++a_local) {
        const int node = mesh().elements[piece.element][4 + a_local];
        const double force = piece.integrals.shape_integrals(a_local) / area;
        for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * node + c, c * num_markers + k, force);
      }
    }
  }
  Eigen::SparseMatrix<double> loads(mesh().num_dofs(), 3 * num_markers);
  loads.setFromTriplets(triplets.begin(), triplets.end());
  return loads;
}

Eigen::SparseMatrix<double> BodyModel::CalcPointInterpolation(
    const std::vector<Eigen::Vector3d>& points_mm) const {
  std::vector<ElementPoint> located;
  located.reserve(points_mm.size());
  for (size_t p = 0; p < points_mm.size(); ++p) {
    const std::optional<ElementPoint> point = locator_.Locate(points_mm[p]);
    if (!point) {
      throw Error(fmt::format("BodyModel: point {} ({}, {}, {}) mm is not inside the body",
                              p,
                              points_mm[p].x(),
                              points_mm[p].y(),
                              points_mm[p].z()));
    }
    located.push_back(*point);
  }
  return CalcInterpolationMatrix(mesh(), located);
}

}  // namespace tac3d::fem
