#include "tac3d/fem/body_model.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tac3d/fem/compliance.h"
#include "tac3d/fem/evaluation.h"
#include "tac3d/fem/test_domes.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

using testing::SmallDome;

TEST(BodyModelOptions, DefaultsAreThePaperPrototype) {
  const BodyModelOptions options;
  EXPECT_NO_THROW(options.Validate());
  EXPECT_EQ(options.num_markers(), 400);
  EXPECT_DOUBLE_EQ(options.marker_pitch_mm, 1.27);
  EXPECT_DOUBLE_EQ(options.SurfaceHeight(0.0), 8.0);
  EXPECT_DOUBLE_EQ(options.sphere_center_z_mm(), -37.0);
  EXPECT_NEAR(options.SurfaceHeight(20.0), -37.0 + std::sqrt(45.0 * 45.0 - 400.0), 1e-12);
}

TEST(BodyModelOptions, ValidateThrowsForEveryBound) {
  const auto throws = [](auto change) {
    BodyModelOptions options;
    change(options);
    EXPECT_THROW(options.Validate(), Error);
  };
  throws([](auto& o) { o.base_diameter_mm = 0; });
  throws([](auto& o) { o.thickness_mm = 0; });
  throws([](auto& o) { o.sphere_radius_mm = -1; });
  throws([](auto& o) { o.marker_pitch_mm = 0; });
  throws([](auto& o) { o.sphere_radius_mm = 19.9; });  // <= base radius
  throws([](auto& o) { o.thickness_mm = 4.6; });       // the sagitta is 4.689 mm
  throws([](auto& o) { o.material.youngs_modulus_mpa = 0; });
  throws([](auto& o) { o.material.poisson_ratio = 0.5; });
  throws([](auto& o) { o.marker_rows = 0; });
  throws([](auto& o) { o.marker_cols = 201; });
  throws([](auto& o) { o.marker_pitch_mm = 1.35; });  // patches reach 19.09 > 0.95 * 20
  throws([](auto& o) { o.marker_depth_mm = 0; });
  throws([](auto& o) { o.marker_depth_mm = 4.3; });  // the body is 4.26 mm deep at the corner
  throws([](auto& o) { o.refinement = 0.2; });
  throws([](auto& o) { o.refinement = 4.1; });
  BodyModelOptions near_bounds;
  near_bounds.marker_depth_mm = 4.2;
  near_bounds.refinement = 0.25;
  EXPECT_NO_THROW(near_bounds.Validate());
  near_bounds.marker_depth_mm = 0.5;
  near_bounds.marker_pitch_mm = 1.34;
  near_bounds.refinement = 4.0;
  EXPECT_NO_THROW(near_bounds.Validate());
}

TEST(BodyModelOptions, JsonRoundTrip) {
  BodyModelOptions options = SmallDome();
  options.lateral_boundary = LateralBoundary::kFixed;
  options.material.poisson_ratio = 0.45;
  options.refinement = 1.5;
  const BodyModelOptions back = BodyModelOptionsFromJson(ToJson(options));
  EXPECT_EQ(ToJson(back), ToJson(options));
  EXPECT_EQ(back.lateral_boundary, LateralBoundary::kFixed);
  nlohmann::json broken = ToJson(options);
  broken.erase("marker_rows");
  EXPECT_THROW(BodyModelOptionsFromJson(broken), Error);
  broken = ToJson(options);
  broken["lateral_boundary"] = "glued";
  EXPECT_THROW(BodyModelOptionsFromJson(broken), Error);
}

TEST(BodyModelOptions, FromSensorConfigMatchesItsMarkersAndBody) {
  SensorConfig config;
  config.elastic_body.thickness_mm = 6.0;
  config.elastic_body.poisson_ratio = 0.45;
  config.elastic_body.lateral_face = LateralFace::kFixed;
  config.markers.rows = 18;
  config.markers.depth_mm = 0.7;
  const BodyModelOptions options = BodyModelOptionsFromSensor(config);
  EXPECT_NO_THROW(options.Validate());
  EXPECT_DOUBLE_EQ(options.thickness_mm, 6.0);
  EXPECT_DOUBLE_EQ(options.material.poisson_ratio, 0.45);
  EXPECT_EQ(options.lateral_boundary, LateralBoundary::kFixed);
  // The FEM's markers are where the sensor model (and so the renderer) puts them.
  const std::vector<Eigen::Vector3d> fem_markers = CalcMarkerPositions(options);
  const std::vector<Eigen::Vector3d> sensor_markers = config.MarkerPositions();
  ASSERT_EQ(fem_markers.size(), sensor_markers.size());
  for (size_t k = 0; k < fem_markers.size(); ++k) {
    EXPECT_LT((fem_markers[k] - sensor_markers[k]).norm(), 1e-9) << "marker " << k;
  }
}

TEST(MarkerPositions, GridOrderAndDepth) {
  const BodyModelOptions options;
  const std::vector<Eigen::Vector3d> markers = CalcMarkerPositions(options);
  ASSERT_EQ(markers.size(), 400u);
  const Eigen::Vector3d center(0, 0, options.sphere_center_z_mm());
  for (const Eigen::Vector3d& p : markers) EXPECT_NEAR((p - center).norm(), 44.5, 1e-12);
  // Marker (row i, col j) has index i * cols + j, x along columns.
  EXPECT_NEAR(markers[0].x(), -9.5 * 1.27, 1e-12);
  EXPECT_NEAR(markers[0].y(), -9.5 * 1.27, 1e-12);
  EXPECT_NEAR(markers[1].x(), -8.5 * 1.27, 1e-12);
  EXPECT_NEAR(markers[20].y(), -8.5 * 1.27, 1e-12);
  EXPECT_NEAR(markers[399].x(), 9.5 * 1.27, 1e-12);
}

TEST(MarkerPositions, GivenPositionsAreValidatedAndKept) {
  BodyModelOptions options = SmallDome();
  options.base_center_mm = Eigen::Vector3d(0.4, -0.2, 1.5);
  const std::vector<Eigen::Vector3d> grid = CalcMarkerPositions(options);
  // The grid moves with the base: 0.5 mm under the outer sphere, whose centre moved too.
  const Eigen::Vector3d sphere_center = options.base_center_mm + Eigen::Vector3d(0, 0, options.sphere_center_z_mm());
  for (const Eigen::Vector3d& p : grid) EXPECT_NEAR((p - sphere_center).norm(), 20.0 - 0.5, 1e-12);
  EXPECT_NEAR(grid[0].x(), 0.4 - 1.5 * 1.27, 1e-12);
  options.marker_positions_mm = grid;
  options.marker_positions_mm[5].z() -= 0.2;
  EXPECT_EQ(CalcMarkerPositions(options), options.marker_positions_mm);
  const BodyModelOptions back = BodyModelOptionsFromJson(ToJson(options));
  EXPECT_EQ(back.marker_positions_mm, options.marker_positions_mm);
  EXPECT_EQ(back.base_center_mm, options.base_center_mm);
  EXPECT_FALSE(ToJson(SmallDome()).contains("marker_positions_mm"));
  EXPECT_FALSE(ToJson(SmallDome()).contains("base_center_mm"));

  BodyModelOptions broken = options;
  broken.marker_positions_mm.pop_back();
  try {
    broken.Validate();
    ADD_FAILURE() << "11 positions for 12 markers accepted";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "BodyModelOptions.marker_positions_mm has 11 positions, the 3 x 4 grid needs 12");
  }
  broken = options;
  broken.marker_positions_mm[3].z() += 0.6;  // above the outer surface
  EXPECT_THROW(broken.Validate(), Error);
  broken = options;
  broken.marker_positions_mm[3].z() = 1.4;  // under the base
  EXPECT_THROW(broken.Validate(), Error);
  broken = options;
  broken.marker_positions_mm[0].x() = 0.4 + 5.8;  // beyond 0.95 of the 6 mm base radius
  EXPECT_THROW(broken.Validate(), Error);
}

TEST(DomeMesh, DefaultMeshIsValidWithThePapersElementSize) {
  const BodyModelOptions options;
  const DomeMesh dome = BuildDomeMesh(options);
  EXPECT_GT(CalcMinJacobianDeterminant(dome.mesh), 0.0);
  // In-plane edge pitch / 3 under the 20 x 20 grid: 60 elements over 25.4 mm.
  EXPECT_EQ(dome.central_elements, 60);
  EXPECT_NEAR(2.0 * dome.central_half_width_mm / dome.central_elements, 1.27 / 3.0, 1e-12);
  const int quads = 60 * 60 + 4 * 60 * dome.ring_elements;
  EXPECT_EQ(dome.mesh.num_elements(), quads * dome.layers);
  EXPECT_EQ(static_cast<int>(dome.outer_surface_elements.size()), quads);
  // The outer surface's nodes lie on the sphere, the base's at z = 0 and fixed, and with a
  // free lateral face nothing else is fixed.
  const Eigen::Vector3d center(0, 0, options.sphere_center_z_mm());
  for (int e : dome.outer_surface_elements) {
    for (int a = 4; a < 8; ++a) {
      EXPECT_NEAR((dome.mesh.nodes[dome.mesh.elements[e][a]] - center).norm(), 45.0, 1e-9);
    }
  }
  int fixed_nodes = 0;
  for (int n = 0; n < dome.mesh.num_nodes(); ++n) {
    const bool fixed = dome.fixed[3 * n];
    EXPECT_EQ(fixed, dome.mesh.nodes[n].z() == 0.0) << "node " << n;
    fixed_nodes += fixed;
  }
  EXPECT_EQ(fixed_nodes, dome.mesh.num_nodes() / (dome.layers + 1));
  // The layer under the outer surface is the thinnest: about pitch / 3 on the axis.
  const int top = dome.CentralTopElement(30, 30);
  const double top_layer = dome.mesh.nodes[dome.mesh.elements[top][6]].z() -
                           dome.mesh.nodes[dome.mesh.elements[top][2]].z();
  EXPECT_GT(top_layer, 0.3);
  EXPECT_LT(top_layer, 1.27 / 3.0);
}

TEST(DomeMesh, ExtremeValidOptionsGivePositiveJacobians) {
  BodyModelOptions coarse;
  coarse.refinement = 0.25;
  BodyModelOptions wide;  // patches reaching 0.947 of the base radius
  wide.marker_pitch_mm = 1.34;
  BodyModelOptions thin = SmallDome();
  thin.thickness_mm = 1.0;
  thin.marker_depth_mm = 0.2;
  BodyModelOptions single = SmallDome();
  single.marker_rows = single.marker_cols = 1;
  for (const BodyModelOptions& options : {coarse, wide, thin, single}) {
    EXPECT_GT(CalcMinJacobianDeterminant(BuildDomeMesh(options).mesh), 0.0);
  }
}

TEST(DomeMesh, FixedLateralFaceFixesTheRim) {
  BodyModelOptions options = SmallDome();
  options.lateral_boundary = LateralBoundary::kFixed;
  const DomeMesh dome = BuildDomeMesh(options);
  for (int n = 0; n < dome.mesh.num_nodes(); ++n) {
    const Eigen::Vector3d& p = dome.mesh.nodes[n];
    const bool on_rim = std::abs(p.head<2>().norm() - 6.0) < 1e-9;
    EXPECT_EQ(dome.fixed[3 * n + 2], on_rim || p.z() == 0.0) << "node " << n;
  }
}

TEST(BodyModel, PatchLoadsAreUnitForcesCentredOnTheMarkers) {
  // At refinement 1.5 the patch edges cut through elements.
  for (double refinement : {1.0, 1.5}) {
    BodyModelOptions options = SmallDome();
    options.refinement = refinement;
    const BodyModel model(options);
    const Eigen::SparseMatrix<double> loads = model.CalcMarkerPatchLoads();
    const int n = options.num_markers();
    ASSERT_EQ(loads.cols(), 3 * n);
    for (int c = 0; c < 3; ++c) {
      for (int k = 0; k < n; ++k) {
        Eigen::Vector3d total = Eigen::Vector3d::Zero();
        Eigen::Vector2d moment = Eigen::Vector2d::Zero();
        for (Eigen::SparseMatrix<double>::InnerIterator it(loads, c * n + k); it; ++it) {
          total(it.row() % 3) += it.value();
          if (it.row() % 3 == c) moment += it.value() * model.mesh().nodes[it.row() / 3].head<2>();
        }
        EXPECT_THAT(total, EigenNear(Eigen::Vector3d::Unit(c), 1e-12));
        // The force's centre is the marker's (x, y), up to the sphere's curvature.
        EXPECT_THAT(moment, EigenNear(model.marker_positions()[k].head<2>().eval(), 2e-3));
      }
    }
  }
}

TEST(BodyModel, PointInterpolationThrowsOutsideTheBody) {
  const BodyModel model(SmallDome());
  EXPECT_NO_THROW(model.CalcPointInterpolation(model.marker_positions()));
  EXPECT_THROW(model.CalcPointInterpolation({Eigen::Vector3d(0, 0, 3.5)}), Error);
  EXPECT_THROW(model.CalcPointInterpolation({Eigen::Vector3d(0, 0, -0.1)}), Error);
}

// The mirror image of H under x -> -x (mirror_x) or y -> -y.
double MirroredEntry(const ComplianceModel& model, int row, int col, bool mirror_x) {
  const int n = model.options.num_markers();
  const int cols = model.options.marker_cols;
  const int rows = model.options.marker_rows;
  const auto mirror = [&](int index) {
    const int c = index / n, k = index % n, i = k / cols, j = k % cols;
    const int mirrored = mirror_x ? i * cols + (cols - 1 - j) : (rows - 1 - i) * cols + j;
    return std::pair{c * n + mirrored, c == (mirror_x ? 0 : 1) ? -1.0 : 1.0};
  };
  const auto [r, sign_r] = mirror(row);
  const auto [s, sign_s] = mirror(col);
  return sign_r * sign_s * model.h(r, s);
}

TEST(ComplianceModel, RespectsTheDomesMirrorSymmetries) {
  const ComplianceModel model = CalcComplianceModel(SmallDome());
  const int size = static_cast<int>(model.h.rows());
  ASSERT_EQ(size, 36);
  const double scale = model.h.cwiseAbs().maxCoeff();
  for (bool mirror_x : {true, false}) {
    double worst = 0.0;
    for (int r = 0; r < size; ++r) {
      for (int s = 0; s < size; ++s) {
        worst = std::max(worst, std::abs(model.h(r, s) - MirroredEntry(model, r, s, mirror_x)));
      }
    }
    EXPECT_LT(worst, 1e-9 * scale) << (mirror_x ? "x mirror" : "y mirror");
  }
  // Pulling a patch outwards moves its marker outwards; pushing it along x moves it along x.
  const int n = 12;
  for (int k = 0; k < n; ++k) {
    EXPECT_GT(model.h(2 * n + k, 2 * n + k), 0.0);
    EXPECT_GT(model.h(k, k), 0.0);
  }
  EXPECT_EQ(model.provenance.num_elements, BuildDomeMesh(SmallDome()).mesh.num_elements());
}

TEST(ComplianceModel, EqualsPerColumnSolves) {
  // H without a solve a column (SparseCholesky::CalcBilinear) against the straightforward way:
  // one full solve for each load case, read at the markers. 4 x 5 markers: 60 cases.
  const BodyModel model(SmallDome(4, 5));
  const ComplianceModel compliance = CalcComplianceModel(model);
  const Eigen::SparseMatrix<double> readout = model.CalcPointInterpolation(model.marker_positions());
  const Eigen::SparseMatrix<double> loads = model.CalcMarkerPatchLoads();
  Eigen::MatrixXd expected(readout.rows(), loads.cols());
  for (int c = 0; c < loads.cols(); ++c) {
    expected.col(c) = readout * model.solver().Solve(Eigen::VectorXd(loads.col(c)));
  }
  EXPECT_THAT(compliance.h, EigenNear(expected, 1e-10 * expected.cwiseAbs().maxCoeff()));
}

TEST(ComplianceModel, IsTheSameForTheSameBodyMoved) {
  // A body moved (its base centre) with its markers given where they moved to is the same
  // body: H is unchanged; the markers are where they were put.
  const ComplianceModel at_origin = CalcComplianceModel(SmallDome());
  BodyModelOptions moved = SmallDome();
  const Eigen::Vector3d offset(-0.4, 0.3, 2.0);
  moved.base_center_mm = offset;
  for (const Eigen::Vector3d& p : at_origin.marker_positions) {
    moved.marker_positions_mm.push_back(p + offset);
  }
  const ComplianceModel model = CalcComplianceModel(moved);
  EXPECT_LT((model.h - at_origin.h).cwiseAbs().maxCoeff(), 1e-9 * at_origin.h.cwiseAbs().maxCoeff());
  EXPECT_EQ(model.marker_positions, moved.marker_positions_mm);
  EXPECT_NE(CalcComplianceCacheKey(moved), CalcComplianceCacheKey(SmallDome()));
}

TEST(ComplianceModel, FixedLateralFaceStiffensTheRim) {
  BodyModelOptions fixed = SmallDome();
  fixed.lateral_boundary = LateralBoundary::kFixed;
  const ComplianceModel free_model = CalcComplianceModel(SmallDome());
  const ComplianceModel fixed_model = CalcComplianceModel(fixed);
  const int n = 12;
  for (int k = 0; k < n; ++k) {
    EXPECT_LT(fixed_model.h(k, k), free_model.h(k, k)) << "marker " << k;
    EXPECT_LT(fixed_model.h(2 * n + k, 2 * n + k), free_model.h(2 * n + k, 2 * n + k));
  }
}

TEST(ComplianceModel, CoarseDomeConvergesUnderRefinement) {
  // The sensor's geometry with a 4 x 4 marker grid: the same check as the eval-labelled one
  // on the full 20 x 20 sensor, at a tenth of the cost.
  BodyModelOptions options;
  options.marker_rows = options.marker_cols = 4;
  const MeshConvergenceResult result = RunMeshConvergence(options, 1.5);
  EXPECT_LT(result.relative_difference, 0.03);
  EXPECT_GT(result.fine_free_dofs, 3 * result.coarse_free_dofs);
}

BodySolverOptions AlwaysTwoGrid() {
  BodySolverOptions solver;
  solver.max_direct_free_dofs = 0;
  return solver;
}

BodyModelOptions SmallDomeWithPoissonRatio(double nu, double refinement = 1.0) {
  BodyModelOptions options = SmallDome();
  options.material.poisson_ratio = nu;
  options.refinement = refinement;
  return options;
}

// The markers' response to every patch load, and what the solve cost.
Eigen::MatrixXd MarkerResponse(const BodyModel& model, SolveSummary* summary = nullptr) {
  return model.solver().CalcResponse(model.CalcPointInterpolation(model.marker_positions()),
                                     model.CalcMarkerPatchLoads(),
                                     false,
                                     100,
                                     summary);
}

TEST(TwoGridSolver, MatchesTheDirectSolution) {
  const BodyModel direct(SmallDome());
  const BodyModel iterative(SmallDome(), false, AlwaysTwoGrid());
  ASSERT_EQ(direct.solver().summary().method, ElasticSolverMethod::kDirect);
  ASSERT_EQ(iterative.solver().summary().method, ElasticSolverMethod::kTwoGridPcg);
  EXPECT_EQ(iterative.solver().summary().num_free_dofs, direct.solver().summary().num_free_dofs);
  EXPECT_LT(iterative.solver().summary().coarse_free_dofs,
            iterative.solver().summary().num_free_dofs / 4);
  SolveSummary summary;
  const Eigen::MatrixXd expected = MarkerResponse(direct);
  const Eigen::MatrixXd actual = MarkerResponse(iterative, &summary);
  // A relative residual of 1e-8 bounds the error by the condition number times that; in the
  // energy norm CG does far better, 3e-10 here.
  EXPECT_LT((actual - expected).norm() / expected.norm(), 1e-8);
  ASSERT_EQ(summary.iterations.size(), 36);
  for (size_t c = 0; c < summary.iterations.size(); ++c) {
    EXPECT_LE(summary.relative_residuals[c], 1e-8) << "case " << c;
    EXPECT_GT(summary.iterations[c], 0) << "case " << c;
  }
  // Prescribed displacements and a single load case go through the same iteration.
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(direct.mesh().num_dofs());
  for (int n = 0; n < direct.mesh().num_nodes(); ++n) prescribed(3 * n) = 0.01;
  const Eigen::VectorXd forces = direct.CalcMarkerPatchLoads().col(30);
  const Eigen::VectorXd u = direct.solver().Solve(forces, prescribed);
  EXPECT_LT((iterative.solver().Solve(forces, prescribed) - u).norm() / u.norm(), 1e-8);
}

TEST(TwoGridSolver, ThreadsSplitTheLoadCasesWithoutChangingThem) {
  // Each thread iterates its own cases; only the coarse factor's block solves (BLAS) may round
  // differently, far below the 1e-8 tolerance. A case lost or swapped would be off by O(1).
  BodySolverOptions one_thread = AlwaysTwoGrid(), three_threads = AlwaysTwoGrid();
  one_thread.pcg.threads = 1;
  three_threads.pcg.threads = 3;
  for (bool mixed_form : {false, true}) {
    one_thread.pcg.mixed_form = three_threads.pcg.mixed_form = mixed_form;
    const BodyModel serial(SmallDomeWithPoissonRatio(0.49, 0.5), false, one_thread);
    const BodyModel parallel(SmallDomeWithPoissonRatio(0.49, 0.5), false, three_threads);
    const Eigen::MatrixXd expected = MarkerResponse(serial);
    EXPECT_LT((MarkerResponse(parallel) - expected).norm() / expected.norm(), 1e-10)
        << "mixed form " << mixed_form;
  }
}

TEST(TwoGridSolver, IterationsStayBoundedUnderRefinement) {
  // Coarse level at half the refinement each time: a two-grid method's iteration count does
  // not grow as the mesh is refined (smoothing alone would need ~2x the iterations per halving).
  std::vector<int> max_iterations;
  for (double refinement : {0.5, 1.0, 1.5}) {
    BodyModelOptions options = SmallDome();
    options.refinement = refinement;
    const BodyModel model(options, false, AlwaysTwoGrid());
    SolveSummary summary;
    MarkerResponse(model, &summary);
    max_iterations.push_back(
        *std::max_element(summary.iterations.begin(), summary.iterations.end()));
  }
  EXPECT_LE(max_iterations[2], 1.25 * max_iterations[0])
      << ::testing::PrintToString(max_iterations);
  EXPECT_LE(max_iterations[1], 1.25 * max_iterations[0])
      << ::testing::PrintToString(max_iterations);
}

TEST(TwoGridSolver, ThrowsWhenItDoesNotConverge) {
  BodySolverOptions solver = AlwaysTwoGrid();
  solver.pcg.max_iterations = 3;
  const BodyModel model(SmallDome(), false, solver);
  EXPECT_THAT([&] { MarkerResponse(model); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("did not converge")));
}

BodySolverOptions AlwaysMixed() {
  BodySolverOptions solver = AlwaysTwoGrid();
  solver.pcg.mixed_form = true;
  return solver;
}

int MaxIterations(const SolveSummary& summary) {
  return *std::max_element(summary.iterations.begin(), summary.iterations.end());
}

TEST(MixedSolver, MatchesTheDirectSolutionUpToNearIncompressibility) {
  for (double nu : {0.3, 0.49, 0.499, 0.4999}) {
    const BodyModel direct(SmallDomeWithPoissonRatio(nu, 0.5));
    const BodyModel mixed(SmallDomeWithPoissonRatio(nu, 0.5), false, AlwaysMixed());
    ASSERT_EQ(mixed.solver().summary().method, ElasticSolverMethod::kTwoGridMixedMinres);
    EXPECT_EQ(mixed.solver().summary().num_pressures, mixed.mesh().num_elements());
    SolveSummary summary;
    const Eigen::MatrixXd expected = MarkerResponse(direct);
    const Eigen::MatrixXd actual = MarkerResponse(mixed, &summary);
    EXPECT_LT((actual - expected).norm() / expected.norm(), 1e-8) << "nu " << nu;
    ASSERT_EQ(summary.iterations.size(), 36);
    for (size_t c = 0; c < summary.iterations.size(); ++c) {
      EXPECT_LE(summary.relative_residuals[c], 1e-8) << "nu " << nu << ", case " << c;
      EXPECT_GT(summary.iterations[c], 0) << "nu " << nu << ", case " << c;
    }
    // Prescribed displacements: K_fp holds the volumetric part that A_r lacks (without it the
    // error is of order 1). The right-hand side -K_fp u_p is large against the load and K's
    // condition grows with K_bulk, so the same residual tolerance bounds u less tightly here:
    // conjugate gradients on K were 2.7e-8 / 2.1e-7 / 2.0e-6 off at nu 0.49 / 0.499 / 0.4999.
    Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(direct.mesh().num_dofs());
    for (int n = 0; n < direct.mesh().num_nodes(); ++n) prescribed(3 * n + 2) = 0.01;
    const Eigen::VectorXd forces = direct.CalcMarkerPatchLoads().col(30);
    const Eigen::VectorXd u = direct.solver().Solve(forces, prescribed);
    EXPECT_LT((mixed.solver().Solve(forces, prescribed) - u).norm() / u.norm(), 1e-7)
        << "nu " << nu;
  }
}

TEST(MixedSolver, IterationsStayBoundedAsPoissonsRatioNearsOneHalf) {
  // Ten times the bulk modulus (0.499 -> 0.4999): MINRES on the mixed form barely notices,
  // conjugate gradients on K (the same two-grid cycle) need several times the iterations.
  const auto max_iterations = [](double nu, bool mixed_form) {
    BodySolverOptions solver = AlwaysTwoGrid();
    solver.pcg.mixed_form = mixed_form;
    const BodyModel model(SmallDomeWithPoissonRatio(nu, 0.5), false, solver);
    SolveSummary summary;
    MarkerResponse(model, &summary);
    return MaxIterations(summary);
  };
  const int mixed_0499 = max_iterations(0.499, true), mixed_04999 = max_iterations(0.4999, true);
  const int pcg_0499 = max_iterations(0.499, false), pcg_04999 = max_iterations(0.4999, false);
  EXPECT_LE(mixed_04999, 1.5 * mixed_0499) << mixed_0499 << " -> " << mixed_04999;
  EXPECT_GT(pcg_04999, 2.0 * pcg_0499) << pcg_0499 << " -> " << pcg_04999;
  EXPECT_LT(mixed_04999, pcg_04999);
}

TEST(MixedSolver, ChosenOnlyWhenAsked) {
  const BodyModel pcg(SmallDomeWithPoissonRatio(0.4999, 0.5), false, AlwaysTwoGrid());
  EXPECT_EQ(pcg.solver().summary().method, ElasticSolverMethod::kTwoGridPcg);
  EXPECT_EQ(pcg.solver().summary().num_pressures, 0);
  const BodyModel mixed(SmallDomeWithPoissonRatio(0.4999, 0.5), false, AlwaysMixed());
  EXPECT_EQ(mixed.solver().summary().method, ElasticSolverMethod::kTwoGridMixedMinres);
}

TEST(MixedSolver, ThrowsWhenItDoesNotConverge) {
  BodySolverOptions solver = AlwaysMixed();
  solver.pcg.max_iterations = 3;
  const BodyModel model(SmallDomeWithPoissonRatio(0.499, 0.5), false, solver);
  EXPECT_THAT([&] { MarkerResponse(model); },
              ::testing::ThrowsMessage<Error>(
                  ::testing::HasSubstr("MINRES on the mixed form did not converge")));
}

TEST(BodySolverOptions, ValidateNamesTheField) {
  const auto throws_naming = [](const BodySolverOptions& options, const std::string& field) {
    EXPECT_THAT([&] { options.Validate(); },
                ::testing::ThrowsMessage<Error>(::testing::HasSubstr(field)));
  };
  EXPECT_NO_THROW(BodySolverOptions{}.Validate());
  BodySolverOptions options;
  options.max_direct_free_dofs = -1;
  throws_naming(options, "max_direct_free_dofs");
  options = {};
  options.coarsening_ratio = 1.0;
  throws_naming(options, "coarsening_ratio");
  for (double tolerance : {0.0, 1.0}) {
    options = {};
    options.pcg.relative_tolerance = tolerance;
    throws_naming(options, "relative_tolerance");
  }
  options = {};
  options.pcg.max_iterations = 0;
  throws_naming(options, "max_iterations");
  options = {};
  options.pcg.smoothing_sweeps = 0;
  throws_naming(options, "smoothing_sweeps");
  options = {};
  options.pcg.block_columns = 0;
  throws_naming(options, "block_columns");
  options = {};
  options.pcg.threads = -1;
  throws_naming(options, "threads");
  options = {};
  options.pcg.mixed_bulk_split = 0.0;
  throws_naming(options, "mixed_bulk_split");
  // A coarse level below the mesh's smallest refinement.
  options = {};
  options.max_direct_free_dofs = 0;
  options.coarsening_ratio = 5.0;
  EXPECT_THAT([&] { BodyModel(SmallDome(), false, options); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("coarsening_ratio")));
}

}  // namespace
}  // namespace tac3d::fem
