#include "tac3d/friction_eval/friction_evaluation.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>

#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/friction/friction_output.h"
#include "tac3d/scene/scene.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A grid mesh on the friction_block's bottom face (z = 8.5 in the world), x in [-10.1, 10.1]
// (columns at odd multiples of 0.1 mm), y in [-5, 5], 0.2 mm spacing, `offset_mm` off the
// face, with mu 1.0 for x < shift and 0.4 beyond: the true boundary is x = 0.
friction::FrictionMapResult BlockMap(double offset_mm, double shift_mm) {
  friction::FrictionMapResult map;
  const int nx = 102, ny = 51;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = -10.1 + 0.2 * i, y = -5.0 + 0.2 * j;
      map.vertices_mm.push_back({x, y, 8.5 - offset_mm});
      map.vertex_normals.push_back(-Eigen::Vector3d::UnitZ());
      map.mu.push_back(x < shift_mm ? 1.0 : 0.4);
      map.confidence.push_back(1.0);
      map.slip_count.push_back(1);
    }
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i;
      map.triangles.push_back({a, a + 1, a + nx + 1});
      map.triangles.push_back({a, a + nx + 1, a + nx});
    }
  }
  return map;
}

TEST(FrictionEvaluation, KnownErrorsOnTheBlock) {
  const Scene scene = BuiltInScene("friction_block");
  // Estimated boundary 0.4 mm into the mu = 0.4 half (mu jumps between the columns at x = 0.3
  // and 0.5, so the 0.7 level is crossed halfway, at x = 0.4), surface 0.05 mm off.
  const friction::FrictionMapResult map = BlockMap(0.05, 0.4);
  // Touched: x in [-10, 12] along y = 0, every 0.25 mm: covered up to x = 10.5 (0.5 mm).
  std::vector<Eigen::Vector3d> touched;
  for (double x = -10.0; x <= 12.0 + 1e-9; x += 0.25) touched.push_back({x, 0.0, 8.5});
  // Slips, every marker pressed with 0.1 N: frame 7 marker 3 truly slipping (found), frame 7
  // marker 4 not (a false slip point), frame 8 marker 5 truly slipping (missed), frame 9
  // marker 6 slipping but first of a stroke. Light slips (0.01 N, under the 0.02 N floor):
  // frame 7 marker 10 found, frame 8 marker 11 missed; neither counts in precision or recall.
  std::map<std::int64_t, FrictionReplayRecorder::FrameTruth> truth;
  for (const std::int64_t frame : {7, 8, 9}) {
    truth[frame].marker_slip = std::vector<std::uint8_t>(400, 0);
    truth[frame].true_normal_force_n = std::vector<double>(400, 0.1);
    truth[frame].has_previous = frame != 9;
  }
  truth[7].marker_slip[3] = 1;
  truth[8].marker_slip[5] = 1;
  truth[9].marker_slip[6] = 1;
  truth[7].marker_slip[10] = truth[8].marker_slip[11] = 1;
  truth[7].true_normal_force_n[10] = truth[8].true_normal_force_n[11] = 0.01;
  friction::FrictionMapResult with_slips = map;
  with_slips.slip_points.resize(3);
  with_slips.slip_points[0].frame_index = 7;
  with_slips.slip_points[0].marker = 3;
  with_slips.slip_points[1].frame_index = 7;
  with_slips.slip_points[1].marker = 4;
  with_slips.slip_points[2].frame_index = 7;
  with_slips.slip_points[2].marker = 10;

  const FrictionEvaluation e = EvaluateFrictionMap(scene, with_slips, truth, touched);
  // Vertices at x = 0.1 and 0.3 (2 columns of 0.2 mm out of 20.2 mm) are wrong by 0.6.
  EXPECT_NEAR(e.mu_mae, 0.6 * 0.4 / 20.2, 1e-6);
  EXPECT_NEAR(e.band_agreement, 1.0 - 0.4 / 20.2, 1e-6);
  ASSERT_EQ(e.boundary_levels.size(), 1u);
  EXPECT_DOUBLE_EQ(e.boundary_levels[0], 0.7);
  EXPECT_NEAR(e.boundary_error_mm, 0.4, 1e-4);
  EXPECT_NEAR(e.boundary_error_max_mm, 0.4, 1e-4);
  EXPECT_NEAR(e.surface_rms_mm, 0.05, 1e-9);
  EXPECT_EQ(e.touched_points, 89);
  EXPECT_EQ(e.covered_points, 83);  // x <= 10.5
  EXPECT_DOUBLE_EQ(e.slip_precision, 0.5);
  EXPECT_DOUBLE_EQ(e.slip_recall, 0.5);
  EXPECT_EQ(e.true_slips, 2);
  EXPECT_EQ(e.light_slips, 2);
  EXPECT_EQ(e.slip_points_at_light_slips, 1);
  EXPECT_DOUBLE_EQ(e.slip_recall_any_cell, 0.5);  // 2 of 4

  // A perfect map: no error, the contour on the boundary; unknown vertices do not count.
  friction::FrictionMapResult exact = BlockMap(0.0, 0.0);
  exact.mu[0] = std::numeric_limits<double>::quiet_NaN();
  const FrictionEvaluation p = EvaluateFrictionMap(scene, exact, {}, touched);
  EXPECT_NEAR(p.mu_mae, 0.0, 1e-12);
  EXPECT_NEAR(p.band_agreement, 1.0, 1e-12);
  EXPECT_NEAR(p.boundary_error_mm, 0.0, 1e-4);  // the contour at x = 0, between -0.1 and 0.1
  EXPECT_EQ(p.known_vertices, p.vertices - 1);
  EXPECT_TRUE(std::isnan(p.slip_precision));

  const FrictionEvaluation all = PoolFrictionEvaluations({e, p});
  EXPECT_EQ(all.touched_points, 2 * 89);
  EXPECT_NEAR(all.mu_mae, 0.5 * e.mu_mae, 1e-4);
  const nlohmann::json j = ToJson(all);
  EXPECT_FALSE(j.at("all_pass").get<bool>());  // slip precision 0.5
  EXPECT_EQ(all.boundary_levels, std::vector<double>{0.7});
  EXPECT_TRUE(j.at("slip_recall").is_number());
}

TEST(FrictionEvaluation, NearestSurfacePointOfEachShape) {
  const Scene bottle = BuiltInScene("friction_bottle");
  const Eigen::Vector3d axis = bottle.objects[0].world_from_object.translation();
  // 1 mm outside the cylinder, below its axis.
  SurfacePoint s = NearestSurfacePoint(bottle, axis + Eigen::Vector3d(0, 3, -31));
  EXPECT_NEAR(s.distance_mm, 1.0, 1e-12);
  EXPECT_TRUE(s.p_in_world_mm.isApprox(axis + Eigen::Vector3d(0, 3, -30), 1e-12));
  EXPECT_DOUBLE_EQ(bottle.objects[0].FrictionAt(s.p_in_object_mm), 0.3);
  // Inside the block, 0.2 mm above its bottom face: the face is nearest.
  const Scene block = BuiltInScene("friction_block");
  s = NearestSurfacePoint(block, {3, 2, 8.7});
  EXPECT_NEAR(s.distance_mm, 0.2, 1e-12);
  EXPECT_NEAR(s.p_in_world_mm.z(), 8.5, 1e-12);
  Scene mesh = block;  // a mesh object without its mesh
  mesh.objects[0].shape = SceneObject::Shape::kMesh;
  EXPECT_THROW(NearestSurfacePoint(mesh, {0, 0, 0}), Error);
  Scene punch = block;
  punch.objects[0].shape = SceneObject::Shape::kFlatPunch;
  EXPECT_THAT(
      [&] {
        NearestSurfacePoint(punch, {0, 0, 0});
      },
      ::testing::ThrowsMessage<Error>(
          ::testing::HasSubstr("known for sphere, cylinder, box and mesh only")));
  FrictionEvaluationOptions bad;
  bad.coverage_distance_mm = 0;
  EXPECT_THROW(bad.Validate(), Error);
}

// friction_block's block (60 x 40 x 10 mm) as a mesh: its bottom face, the one the sensor
// strokes, tessellated with vertex columns at odd multiples of 0.1 mm (and its edges), the other
// faces two triangles each; per-vertex mu 1.0 for x < 0 and 0.4 beyond, so the nearest vertex's
// mu changes at x = 0, where the analytic block's regions change it.
TriangleMesh BlockMesh() {
  TriangleMesh mesh;
  std::vector<double> xs = {-30.0}, ys = {-20.0};
  for (double x = -29.9; x < 30.0; x += 0.2) xs.push_back(x);
  for (double y = -19.9; y < 20.0; y += 0.2) ys.push_back(y);
  xs.push_back(30.0);
  ys.push_back(20.0);
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  for (const double y : ys) {
    for (const double x : xs) mesh.vertices.push_back({x, y, -5.0});
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i;  // outward normal -z: clockwise seen from +z
      mesh.triangles.push_back({a, a + nx + 1, a + 1});
      mesh.triangles.push_back({a, a + nx, a + nx + 1});
    }
  }
  // The top face's corners; the sides join the bottom's corners to them.
  const int b00 = 0, b10 = nx - 1, b01 = (ny - 1) * nx, b11 = ny * nx - 1;
  const int t0 = static_cast<int>(mesh.vertices.size());
  for (const Eigen::Vector3d& c : {Eigen::Vector3d(-30, -20, 5),
                                   Eigen::Vector3d(30, -20, 5),
                                   Eigen::Vector3d(-30, 20, 5),
                                   Eigen::Vector3d(30, 20, 5)}) {
    mesh.vertices.push_back(c);
  }
  const int t00 = t0, t10 = t0 + 1, t01 = t0 + 2, t11 = t0 + 3;
  const auto quad = [&](int a, int b, int c, int d) {  // counter-clockwise from outside
    mesh.triangles.push_back({a, b, c});
    mesh.triangles.push_back({a, c, d});
  };
  quad(t00, t10, t11, t01);  // top
  quad(b00, b10, t10, t00);  // y = -20
  quad(b10, b11, t11, t10);  // x = +30
  quad(b11, b01, t01, t11);  // y = +20
  quad(b01, b00, t00, t01);  // x = -30
  std::vector<double>& mu = mesh.vertex_properties["mu"];
  for (const Eigen::Vector3d& v : mesh.vertices) mu.push_back(v.x() < 0 ? 1.0 : 0.4);
  return mesh;
}

// A scene of one mesh object read from `ply` (written into `dir`) at `position_mm`,
// `rpy_deg`, its mu per vertex.
Scene MeshScene(const TriangleMesh& ply,
                const std::string& dir,
                const std::string& position_mm,
                const std::string& rpy_deg) {
  PlyWriteOptions binary;
  binary.format = PlyFormat::kBinaryLittleEndian;
  WritePly(ply, dir + "/object.ply", binary);
  return ParseScene(fmt::format(R"(
name: mesh
objects:
  - {{name: object, shape: mesh, ply: object.ply, position_mm: {}, rpy_deg: {},
     friction: {{default: 0.5, vertex_property: mu}}}}
trajectory: {{steps: 2, keyframes: [{{t_s: 0, position_mm: [0, 0, 0]}}, {{t_s: 1, position_mm: [0, 0, 0]}}]}}
)",
                                position_mm,
                                rpy_deg),
                    "mesh.yaml",
                    dir);
}

// The block as a PLY mesh gives the analytic block's truth: the same figures on the same map.
TEST(FrictionEvaluation, MeshBlockGivesTheAnalyticBlocksTruth) {
  const Scene analytic = BuiltInScene("friction_block");
  const Scene mesh = MeshScene(
      BlockMesh(), testing::MakeTempDir("friction_eval_mesh_block"), "[0, 0, 13.5]", "[0, 0, 0]");
  std::vector<Eigen::Vector3d> touched;
  for (double x = -10.0; x <= 12.0 + 1e-9; x += 0.25) touched.push_back({x, 0.3, 8.5 + 0.01 * x});
  for (const double offset : {0.05, -0.1}) {  // the map under the face, and inside the block
    SCOPED_TRACE(offset);
    const friction::FrictionMapResult map = BlockMap(offset, 0.4);
    const FrictionEvaluation a = EvaluateFrictionMap(analytic, map, {}, touched);
    const FrictionEvaluation m = EvaluateFrictionMap(mesh, map, {}, touched);
    EXPECT_NEAR(m.mu_mae, a.mu_mae, 1e-12);
    EXPECT_NEAR(m.mu_mae, 0.6 * 0.4 / 20.2, 1e-6);
    EXPECT_NEAR(m.band_agreement, a.band_agreement, 1e-12);
    ASSERT_EQ(m.boundary_levels, a.boundary_levels);
    EXPECT_NEAR(m.boundary_error_mm, a.boundary_error_mm, 1e-5);
    EXPECT_NEAR(m.boundary_error_mm, 0.4, 1e-4);
    EXPECT_NEAR(m.surface_rms_mm, std::abs(offset), 1e-9);
    EXPECT_EQ(m.covered_points, a.covered_points);
  }
  // The touched points projected: onto the face, the same point in the world.
  for (const Eigen::Vector3d& p : touched) {
    EXPECT_THAT(NearestSurfacePoint(mesh, p).p_in_world_mm,
                EigenNear(NearestSurfacePoint(analytic, p).p_in_world_mm, 1e-9));
  }
}

// A UV sphere of `radius_mm`: `rings` bands of latitude, `segments` of longitude, and its poles.
TriangleMesh SphereMesh(double radius_mm, int rings, int segments) {
  TriangleMesh mesh;
  mesh.vertices.push_back({0, 0, -radius_mm});
  for (int r = 1; r < rings; ++r) {
    const double theta = M_PI * r / rings;  // from the south pole
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * M_PI * s / segments;
      mesh.vertices.push_back(radius_mm * Eigen::Vector3d(std::sin(theta) * std::cos(phi),
                                                          std::sin(theta) * std::sin(phi),
                                                          -std::cos(theta)));
    }
  }
  mesh.vertices.push_back({0, 0, radius_mm});
  const int north = static_cast<int>(mesh.vertices.size()) - 1;
  const auto at = [segments](int ring, int s) {
    return 1 + (ring - 1) * segments + (s % segments);
  };
  for (int s = 0; s < segments; ++s) {
    mesh.triangles.push_back({0, at(1, s + 1), at(1, s)});
    mesh.triangles.push_back({north, at(rings - 1, s), at(rings - 1, s + 1)});
    for (int r = 1; r + 1 < rings; ++r) {
      mesh.triangles.push_back({at(r, s), at(r, s + 1), at(r + 1, s + 1)});
      mesh.triangles.push_back({at(r, s), at(r + 1, s + 1), at(r + 1, s)});
    }
  }
  return mesh;
}

// A sphere mesh with two materials, turned and moved: its surface within the facets' sagitta
// of the analytic sphere's, and the right mu (so band) at every point more than an edge from
// the boundary, in the same world frame.
TEST(FrictionEvaluation, MeshSphereWithTwoMaterialsGivesTheAnalyticTruth) {
  const double radius = 10.0;
  const int rings = 64, segments = 128;  // edges up to 2 pi 10 / 128 = 0.49 mm
  TriangleMesh ply = SphereMesh(radius, rings, segments);
  std::vector<double>& mu = ply.vertex_properties["mu"];
  for (const Eigen::Vector3d& v : ply.vertices) mu.push_back(v.x() <= 2.0 ? 1.0 : 0.3);
  const Scene mesh = MeshScene(
      ply, testing::MakeTempDir("friction_eval_mesh_sphere"), "[3, -2, 20]", "[30, -20, 45]");
  Scene analytic = mesh;
  SceneObject& sphere = analytic.objects[0];
  sphere.shape = SceneObject::Shape::kSphere;
  sphere.radius_mm = radius;
  sphere.mesh = nullptr;
  sphere.friction.vertex_property.clear();
  sphere.friction.default_mu = 0.3;
  FrictionRegion rubber;
  rubber.min_mm = Eigen::Vector3d(-11, -11, -11);
  rubber.max_mm = Eigen::Vector3d(2, 11, 11);
  rubber.mu = 1.0;
  sphere.friction.regions = {rubber};
  // The largest gap between a facet and the sphere: a band's facet spans 2 pi r / segments
  // round and pi r / rings along; its centre lies r (1 - cos(half its diagonal / r)) inside.
  const double half_diagonal =
      0.5 * std::hypot(2 * M_PI * radius / segments, M_PI * radius / rings);
  const double sagitta = radius * (1 - std::cos(half_diagonal / radius));
  // A point up to 2 mm off the surface projects along its facet's normal, which turns from the
  // radius by up to half_diagonal / radius: its nearest point moves sideways by up to that
  // angle times 2 mm.
  const double sideways = sagitta + 2.0 * half_diagonal / radius;
  std::mt19937_64 rng(testing::kRandomSeed);
  std::normal_distribution<double> direction(0, 1);
  std::uniform_real_distribution<double> depth(-2, 2);
  int away_from_boundary = 0;
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d u =
        Eigen::Vector3d(direction(rng), direction(rng), direction(rng)).normalized();
    const Eigen::Vector3d p = mesh.objects[0].world_from_object * ((radius + depth(rng)) * u);
    const SurfacePoint m = NearestSurfacePoint(mesh, p), a = NearestSurfacePoint(analytic, p);
    ASSERT_EQ(m.object, 0);
    EXPECT_NEAR(m.distance_mm, a.distance_mm, sagitta);
    EXPECT_THAT(m.p_in_world_mm, EigenNear(a.p_in_world_mm, sideways));
    EXPECT_THAT(m.p_in_object_mm, EigenNear(a.p_in_object_mm, sideways));
    if (std::abs(a.p_in_object_mm.x() - 2.0) < 0.5) continue;  // within an edge of the boundary
    ++away_from_boundary;
    const double mesh_mu = mesh.objects[0].FrictionAt(m.p_in_object_mm);
    ASSERT_DOUBLE_EQ(mesh_mu, sphere.FrictionAt(a.p_in_object_mm)) << a.p_in_object_mm.transpose();
    EXPECT_EQ(
        friction::BandOf(mesh_mu),
        a.p_in_object_mm.x() <= 2.0 ? friction::FrictionBand::kHigh : friction::FrictionBand::kLow);
  }
  EXPECT_GT(away_from_boundary, 1800);
  EXPECT_LT(sagitta, 0.01);
  EXPECT_LT(sideways, 0.08);
}

// What the evaluation cannot take a truth from is refused, naming the object.
TEST(FrictionEvaluation, MalformedMeshesAreRefused) {
  const std::string dir = testing::MakeTempDir("friction_eval_bad_mesh");
  TriangleMesh line;
  line.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  line.triangles = {{0, 1, 2}};
  line.vertex_properties["mu"] = {0.5, 0.5, 0.5};
  const Scene flat = MeshScene(line, dir, "[0, 0, 10]", "[0, 0, 0]");
  EXPECT_THAT(
      [&] {
        NearestSurfacePoint(flat, {0, 0, 0});
      },
      ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
          "the mesh object 'object' ('object.ply') has no triangle with an area")));
  // A friction map's PLY with its unknown vertices (NaN mu) as the object: no truth there.
  TriangleMesh unknown = BlockMesh();
  unknown.vertex_properties["mu"][7] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT([&] { MeshScene(unknown, dir, "[0, 0, 13.5]", "[0, 0, 0]"); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("a vertex's mu")));
}

// The chain after the pipeline on the friction_block scene: its trajectory's poses, frames
// made from them (markers within 4.5 mm of the sensor's axis pressed flat on the block, every
// one slipping while the sensor slides, |F_t| = true mu x F_n, noise as the pipeline's), the
// recorder (strokes broken at the lifts), the map and the evaluation against the scene's
// truth. Loose bounds: equations 5 and 6 blur the boundary over r = 1.5 mm.
TEST(FrictionEvaluation, SyntheticFramesAlongTheBlockScene) {
  const Scene scene = BuiltInScene("friction_block");
  const SceneObject& block = scene.objects[0];
  const double face_z = block.world_from_object.translation().z() - 0.5 * block.size_mm.z();
  std::mt19937_64 rng(testing::kRandomSeed);
  std::normal_distribution<double> noise(0.0, 0.002), force_noise(0.0, 0.0005);
  friction::FrictionMapOptions options;
  options.cover_thickness_mm = 0.5;
  friction::FrictionMapBuilder builder(options);
  FrictionReplayRecorder recorder(builder);
  std::vector<Eigen::Vector3d> touched;
  const Trajectory& t = scene.trajectory;
  Rigid3 previous = t.PoseAt(t.StepTime(0));
  for (int k = 0; k < t.steps; k += 2) {
    const Rigid3 pose = t.PoseAt(t.StepTime(k));
    TwinStep step;
    step.index = k;
    step.world_from_sensor = pose;
    step.marker_slip.assign(400, 0);
    step.marker_forces_n.assign(400, Eigen::Vector3d::Zero());
    TactileFrame frame = TactileFrame::Sized(20, 20);
    frame.index = k;
    frame.timestamp_s = t.StepTime(k);
    const bool pressed = pose.translation().z() + 8.0 > face_z;
    const bool moving = (pose.translation() - previous.translation()).norm() > 0.05;
    previous = pose;
    for (int i = 0; i < 400; ++i) {
      const Eigen::Vector2d q((i % 20 - 9.5) * 1.27, (i / 20 - 9.5) * 1.27);
      frame.normals[i] = Eigen::Vector3d(q.x() / 45.0, q.y() / 45.0, 1.0).normalized();
      frame.positions_mm[i] = Eigen::Vector3d(q.x(), q.y(), 7.5 - q.squaredNorm() / 90.0);
      if (!pressed || q.norm() > 4.5) continue;
      const Eigen::Vector3d world(
          pose.translation().x() + q.x(), pose.translation().y() + q.y(), face_z - 0.5);
      frame.positions_mm[i] =
          pose.inverse() * world + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      frame.normals[i] = Eigen::Vector3d::UnitZ();
      const double mu = block.FrictionAt(block.world_from_object.inverse() *
                                         (world + Eigen::Vector3d(0, 0, 0.5)));
      const double fn = 0.1 - 0.015 * q.norm();
      step.marker_forces_n[i] = Eigen::Vector3d(moving ? mu * fn : 0.0, 0.0, -fn);
      frame.forces_n[i] = step.marker_forces_n[i] +
                          Eigen::Vector3d(force_noise(rng), force_noise(rng), force_noise(rng));
      step.marker_slip[i] = moving;
      touched.push_back(world + Eigen::Vector3d(0, 0, 0.5));
    }
    recorder.Add(step, frame);
  }
  EXPECT_EQ(recorder.strokes(), 3);
  const friction::FrictionMapResult map = builder.Build();
  ASSERT_EQ(map.summary.status, friction::FrictionMapStatus::kOk) << map.summary.message;
  const FrictionEvaluation e = EvaluateFrictionMap(scene, map, recorder.truth(), touched);
  std::printf("%s\n", e.BriefReport().c_str());
  EXPECT_LT(e.mu_mae, 0.05);
  EXPECT_GT(e.band_agreement, 0.9);
  EXPECT_LT(e.boundary_error_mm, 1.0);
  EXPECT_GT(e.coverage, 0.9);
  EXPECT_LT(e.surface_rms_mm, 0.02);
  EXPECT_GT(e.slip_precision, 0.99);
  EXPECT_GT(e.slip_recall, 0.95);
}

}  // namespace
}  // namespace tac3d
