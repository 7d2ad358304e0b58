#include "tac3d/simulation/twin_body.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <filesystem>
#include <fstream>
#include <memory>

#include "tac3d/pipeline/pipeline.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

namespace tac3d::simulation {
namespace {

using ::testing::HasSubstr;

// A small dome (3 x 3 markers) so a model builds in about a second.
fem::BodyModelOptions SmallBody() {
  fem::BodyModelOptions body;
  body.base_diameter_mm = 12.0;
  body.thickness_mm = 3.0;
  body.sphere_radius_mm = 20.0;
  body.marker_rows = body.marker_cols = 3;
  return body;
}

TwinBodyOptions SmallOptions() {
  TwinBodyOptions options;
  options.margin_mm = 0.8;  // 2 cells
  options.quadrature_points_per_side = 2;
  return options;
}

// The 2 x 2 points SmallOptions' quadrature spreads a cell's load over, 0.01 mm under the
// sphere (TwinBodyOptions::surface_depth_mm), computed here from their definition.
std::vector<Eigen::Vector3d> CellQuadraturePoints(const TwinBodyModel& model, int node) {
  const Eigen::Vector2d c = model.grid.node_position_mm(node);
  const double r = model.body.sphere_radius_mm;
  std::vector<Eigen::Vector3d> points;
  for (const double fy : {-0.25, 0.25}) {
    for (const double fx : {-0.25, 0.25}) {
      const double x = c.x() + fx * model.grid.dx_mm, y = c.y() + fy * model.grid.dy_mm;
      points.emplace_back(x, y, model.body.sphere_center_z_mm() + std::sqrt(r * r - x * x - y * y) - 0.01);
    }
  }
  return points;
}

const TwinBodyModel& SmallBodyModel() {
  static const TwinBodyModel model = CalcTwinBodyModel(SmallBody(), SmallOptions());
  return model;
}

TEST(TwinContactGrid, MarkerPatchesHoldWholeCells) {
  const fem::BodyModelOptions body = TwinBodyModelOptions(DefaultSensorConfig(), TwinDeviation{});
  const contact::SurfaceGrid grid = MakeTwinContactGrid(body, TwinBodyOptions{});
  EXPECT_NEAR(grid.dx_mm, 1.27 / 3.0, 1e-12);
  EXPECT_EQ(grid.nx, 20 * 3 + 2 * 5);  // 2 mm margin = 4.7 cells, rounded up
  EXPECT_EQ(grid.ny, grid.nx);
  TwinBodyModel model;
  model.body = body;
  model.grid = grid;
  std::vector<int> cells(400, 0);
  for (const int m : model.CalcNodeMarkers()) {
    if (m >= 0) ++cells[m];
  }
  for (int m = 0; m < 400; ++m) EXPECT_EQ(cells[m], 9) << m;
  // Each node of marker k's patch lies within half a pitch of the marker.
  const std::vector<int> markers = model.CalcNodeMarkers();
  const std::vector<Eigen::Vector3d> rest = fem::CalcMarkerPositions(body);
  for (int i = 0; i < grid.num_nodes(); ++i) {
    if (markers[i] < 0) continue;
    const Eigen::Vector2d d = grid.node_position_mm(i) - rest[markers[i]].head<2>();
    EXPECT_LT(d.cwiseAbs().maxCoeff(), 0.5 * 1.27) << i;
  }
}

TEST(TwinBodyModelOptions, AppliesTheDeviation) {
  const SensorConfig sensor = DefaultSensorConfig();
  const TwinDeviation deviation{1.5, 1.1, 0.99};
  const fem::BodyModelOptions body = TwinBodyModelOptions(sensor, deviation);
  EXPECT_DOUBLE_EQ(body.refinement, 1.5);
  EXPECT_DOUBLE_EQ(body.material.youngs_modulus_mpa, 1.1 * sensor.elastic_body.youngs_modulus_mpa);
  EXPECT_DOUBLE_EQ(body.material.poisson_ratio, 0.99 * sensor.elastic_body.poisson_ratio);
}

// An imported sensor's twin body is its gel (VendorBodyModelOptions) off nominal, with the
// markers where the pipeline's rest state puts them, in the vendor's order; each marker's patch
// holds the grid's nodes around it, whose surface points lie over it.
TEST(TwinBodyModelOptions, ImportedSensorIsItsGelWithTheMarkersAtRest) {
  const SensorConfig sensor = testing::FixtureVendorSensor();
  const TwinDeviation deviation{1.25, 1.1, 0.99};
  const fem::BodyModelOptions body = TwinBodyModelOptions(sensor, deviation);
  const std::vector<Eigen::Vector3d> rest = RestMarkerPositions(sensor);
  const std::vector<Eigen::Vector3d> markers = fem::CalcMarkerPositions(body);
  ASSERT_EQ(markers.size(), rest.size());
  for (size_t m = 0; m < rest.size(); ++m) EXPECT_EQ(markers[m], rest[m]) << m;
  EXPECT_DOUBLE_EQ(body.refinement, 1.25);
  EXPECT_DOUBLE_EQ(body.material.youngs_modulus_mpa, 1.1 * sensor.elastic_body.youngs_modulus_mpa);
  EXPECT_DOUBLE_EQ(body.material.poisson_ratio, 0.99 * sensor.elastic_body.poisson_ratio);
  EXPECT_FALSE(body.base_center_mm.isZero());  // the dome's axis is off the sensor's origin

  TwinBodyModel model;
  model.body = body;
  model.grid = MakeTwinContactGrid(body, TwinBodyOptions{});
  model.marker_positions = markers;
  const std::vector<int> node_markers = model.CalcNodeMarkers();
  const std::vector<Eigen::Vector3d> surface = model.CalcNodeSurfacePoints();
  std::vector<int> cells(markers.size(), 0);
  for (int i = 0; i < model.grid.num_nodes(); ++i) {
    const int m = node_markers[i];
    if (m < 0) continue;
    ++cells[m];
    const Eigen::Vector3d above = surface[i] - markers[m];
    EXPECT_LE(above.head<2>().cwiseAbs().maxCoeff(), 0.5 * body.marker_pitch_mm) << i;
    // The outer surface is the markers' sphere grown by the marker depth.
    EXPECT_GT(above.z(), 0.3 * body.marker_depth_mm) << i;
    EXPECT_LT(above.z(), 2.0 * body.marker_depth_mm) << i;
  }
  for (size_t m = 0; m < markers.size(); ++m) EXPECT_GE(cells[m], 4) << m;
}

TEST(TwinBody, KernelIsReciprocalAndPositiveDefinite) {
  const TwinBodyModel& model = SmallBodyModel();
  // FEM reciprocity before symmetrisation: the cell load and the point readout differ only by
  // the quadrature, so the two halves agree to a few percent.
  EXPECT_LT(model.provenance.kernel_asymmetry, 0.05);
  EXPECT_GT(model.provenance.kernel_asymmetry, 0.0);
  // Unclamped: the truncation of this thin (3 mm) dome's kernel at 5.4 mm, where it has decayed
  // to ~5% only, leaves symbol eigenvalues slightly negative (< 1% of the largest).
  const contact::ConvolutionCompliance raw(model.grid, model.kernel, 0.0);
  const contact::KernelSymbolReport& symbol = raw.symbol_report();
  EXPECT_GT(symbol.max_eigenvalue, 0.0);
  EXPECT_GT(symbol.min_eigenvalue, -0.01 * symbol.max_eigenvalue);
  std::printf("symbol eigenvalues [%.3g, %.3g] mm/MPa, truncation ratio %.3g\n",
              symbol.min_eigenvalue,
              symbol.max_eigenvalue,
              model.provenance.kernel_truncation_ratio);
  // Clamped as the simulation uses it: symmetric positive definite, and close to the raw one.
  const contact::ConvolutionCompliance clamped(model.grid, model.kernel, model.options.clamp_floor);
  EXPECT_GT(clamped.symbol_report().num_clamped, 0);
  const Eigen::MatrixXd c = clamped.CalcDenseMatrix();
  EXPECT_LT((c - c.transpose()).cwiseAbs().maxCoeff(), 1e-12 * c.cwiseAbs().maxCoeff());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(c);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  EXPECT_LT((c - raw.CalcDenseMatrix()).cwiseAbs().maxCoeff(), 0.02 * c.cwiseAbs().maxCoeff());
  // Pressing in is positive in both the pressure and the displacement.
  EXPECT_GT(model.kernel.at(2, 2, 0, 0), 0.0);
  EXPECT_GT(model.kernel.at(0, 0, 0, 0), 0.0);
}

// The kernel against FEM solves of the same cell loads: exact at the centre node up to the
// symmetrisation, approximate elsewhere (the dome is not translation invariant).
TEST(TwinBody, KernelAgreesWithDirectFemColumns) {
  const TwinBodyModel& model = SmallBodyModel();
  const contact::SurfaceGrid& grid = model.grid;
  const fem::BodyModel fem_model(model.body);
  const std::vector<Eigen::Vector3d> nodes = model.CalcNodeSurfacePoints();
  std::vector<Eigen::Vector3d> readout_points;
  for (const Eigen::Vector3d& p : nodes) readout_points.push_back(p - Eigen::Vector3d(0, 0, 0.01));
  const Eigen::SparseMatrix<double> readout = fem_model.CalcPointInterpolation(readout_points);
  const contact::ConvolutionCompliance compliance(model.grid, model.kernel, 0.0);
  const Eigen::MatrixXd dense = compliance.CalcDenseMatrix();
  const int n = grid.num_nodes();
  const double sign[3] = {1, 1, -1};
  const auto column_error = [&](int node) {
    // 2 x 2 point forces over the cell, as SmallOptions' quadrature.
    const Eigen::SparseMatrix<double> p =
        fem_model.CalcPointInterpolation(CellQuadraturePoints(model, node));
    Eigen::SparseMatrix<double> average(12, 3);
    for (int in = 0; in < 3; ++in) {
      for (int s = 0; s < 4; ++s) average.insert(in * 4 + s, in) = 0.25;
    }
    const Eigen::SparseMatrix<double> loads = p.transpose() * average;
    const Eigen::MatrixXd u = fem_model.solver().CalcResponse(readout, loads);
    double error = 0.0, scale = 0.0;
    for (int out = 0; out < 3; ++out) {
      for (int in = 0; in < 3; ++in) {
        for (int f = 0; f < n; ++f) {
          const double fem = sign[out] * sign[in] * grid.cell_area_mm2() * u(out * n + f, in);
          error = std::max(error, std::abs(fem - dense(out * n + f, in * n + node)));
          scale = std::max(scale, std::abs(fem));
        }
      }
    }
    return error / scale;
  };
  const int centre = (grid.ny / 2) * grid.nx + grid.nx / 2;
  const double centre_error = column_error(centre);
  const double corner_error = column_error(2 * grid.nx + 2);
  std::printf("kernel vs FEM: centre column %.2e, off-centre column %.2e (relative max)\n",
              centre_error,
              corner_error);
  // Measured 0.6% and 7.1%: the centre column differs by the symmetrisation only; 2 mm off
  // the centre of a 3 mm dome the translation-invariant kernel is an approximation.
  EXPECT_LT(centre_error, 0.02);
  EXPECT_LT(corner_error, 0.15);
  EXPECT_GT(corner_error, centre_error);
}

TEST(TwinBody, MarkerResponseMatchesForwardSolves) {
  const TwinBodyModel& model = SmallBodyModel();
  const fem::BodyModel fem_model(model.body);
  const Eigen::SparseMatrix<double> markers =
      fem_model.CalcPointInterpolation(model.marker_positions);
  const contact::SurfaceGrid& grid = model.grid;
  const int n = grid.num_nodes();
  for (const int node : {(grid.ny / 2) * grid.nx + grid.nx / 2, 3 * grid.nx + 5}) {
    const Eigen::SparseMatrix<double> p =
        fem_model.CalcPointInterpolation(CellQuadraturePoints(model, node));
    for (int dir = 0; dir < 3; ++dir) {
      Eigen::VectorXd load = Eigen::VectorXd::Zero(fem_model.mesh().num_dofs());
      for (int s = 0; s < 4; ++s) load += 0.25 * p.row(dir * 4 + s).transpose();
      const Eigen::VectorXd u = markers * fem_model.solver().Solve(load);
      const Eigen::VectorXd m = model.marker_response.view().col(dir * n + node);
      EXPECT_LT((u - m).cwiseAbs().maxCoeff(), 1e-9 * u.cwiseAbs().maxCoeff())
          << "node " << node << " direction " << dir;
    }
  }
}

void ExpectSameModel(const TwinBodyModel& a, const TwinBodyModel& b) {
  EXPECT_TRUE(a.marker_response.view() == b.marker_response.view());  // bit for bit
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) EXPECT_TRUE(a.kernel.k[out][in] == b.kernel.k[out][in]);
  }
  EXPECT_EQ(ToJson(a.provenance), ToJson(b.provenance));
  EXPECT_EQ(a.grid.nx, b.grid.nx);
}

TEST(TwinBodyCache, HitStaleAndCorruptFiles) {
  const std::string dir = testing::MakeTempDir("twin_body_cache");
  const TwinBodyCacheResult built =
      LoadOrBuildTwinBodyModel(SmallBody(), SmallOptions(), dir, false);
  EXPECT_EQ(built.status, fem::ComplianceCacheStatus::kBuiltMissing);
  const TwinBodyCacheResult loaded =
      LoadOrBuildTwinBodyModel(SmallBody(), SmallOptions(), dir, false);
  EXPECT_EQ(loaded.status, fem::ComplianceCacheStatus::kLoaded) << loaded.reason;
  ExpectSameModel(built.model, loaded.model);
  ExpectSameModel(LoadTwinBodyModel(built.path), built.model);
  // Loaded, the marker response stays in the file's pages (shared between processes).
  EXPECT_FALSE(built.model.marker_response.mapped());
  EXPECT_TRUE(loaded.model.marker_response.mapped());

  // Stale: another model's file under this key's name.
  TwinBodyOptions other = SmallOptions();
  other.quadrature_points_per_side = 1;
  SaveTwinBodyModel(CalcTwinBodyModel(SmallBody(), other), built.path);
  const TwinBodyCacheResult stale =
      LoadOrBuildTwinBodyModel(SmallBody(), SmallOptions(), dir, false);
  EXPECT_EQ(stale.status, fem::ComplianceCacheStatus::kRebuiltStale) << stale.reason;
  EXPECT_THAT(stale.reason, HasSubstr("other inputs or code"));

  // Corrupt: one byte flipped in the middle, then truncated.
  {
    std::fstream f(built.path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(std::filesystem::file_size(built.path) / 2));
    f.put('\x5a');
  }
  const TwinBodyCacheResult corrupt =
      LoadOrBuildTwinBodyModel(SmallBody(), SmallOptions(), dir, false);
  EXPECT_EQ(corrupt.status, fem::ComplianceCacheStatus::kRebuiltCorrupt);
  EXPECT_THAT(corrupt.reason, HasSubstr("checksum"));
  std::filesystem::resize_file(built.path, 100);
  const TwinBodyCacheResult truncated =
      LoadOrBuildTwinBodyModel(SmallBody(), SmallOptions(), dir, false);
  EXPECT_EQ(truncated.status, fem::ComplianceCacheStatus::kRebuiltCorrupt);
  EXPECT_THAT(truncated.reason, HasSubstr("truncated"));
  ExpectSameModel(LoadTwinBodyModel(built.path), truncated.model);
}

// Simulations of one body in one process: one model (GetSharedModel, tested in util), the cached
// file's, reported with its cache file.
TEST(TwinBodyCache, OneBodySharesOneModelInTheProcess) {
  const std::string dir = testing::MakeTempDir("twin_body_shared");
  const TwinBodyOptions options = SmallOptions();
  SharedModelSource built;
  std::shared_ptr<const TwinBodyModel> first =
      LoadSharedTwinBodyModel(SmallBody(), options, dir, false, &built);
  EXPECT_EQ(first, LoadSharedTwinBodyModel(SmallBody(), options, dir, false, nullptr));
  const TwinBodyCacheResult file = LoadOrBuildTwinBodyModel(SmallBody(), options, dir, false);
  EXPECT_EQ(file.status, fem::ComplianceCacheStatus::kLoaded);
  ExpectSameModel(*first, file.model);
  EXPECT_EQ(built.path, file.path);
  EXPECT_EQ(built.status, fem::ComplianceCacheStatus::kBuiltMissing);
}

TEST(TwinBody, RefusesABodyTooLargeForADirectFactor) {
  TwinBodyOptions options = SmallOptions();
  options.max_direct_free_dofs = 1000;
  try {
    CalcTwinBodyModel(SmallBody(), options);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("free DOFs, more than the 1000"));
    EXPECT_THAT(e.what(), HasSubstr("mesh_refinement <= 1.5"));
  }
}

TEST(TwinBodyOptions, ValidateNamesTheField) {
  const auto error = [](auto change) {
    TwinBodyOptions o;
    change(o);
    try {
      o.Validate();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(error([](auto& o) { o.cells_per_pitch = 0; }), HasSubstr("cells_per_pitch"));
  EXPECT_THAT(error([](auto& o) { o.margin_mm = -1; }), HasSubstr("margin_mm"));
  EXPECT_THAT(error([](auto& o) { o.active_radius_fraction = 1.5; }),
              HasSubstr("active_radius_fraction"));
  EXPECT_THAT(error([](auto& o) { o.kernel_radius_fraction = 0; }),
              HasSubstr("kernel_radius_fraction"));
  EXPECT_THAT(error([](auto& o) { o.quadrature_points_per_side = 9; }), HasSubstr("quadrature"));
  EXPECT_THAT(error([](auto& o) { o.surface_depth_mm = 0.2; }), HasSubstr("surface_depth_mm"));
  EXPECT_THAT(error([](auto& o) { o.clamp_floor = 0.1; }), HasSubstr("clamp_floor"));
  EXPECT_THAT(error([](auto& o) { o.max_direct_free_dofs = 0; }),
              HasSubstr("max_direct_free_dofs"));
  EXPECT_EQ(error([](auto&) {}), "");
}

}  // namespace
}  // namespace tac3d::simulation
