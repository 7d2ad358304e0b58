#include "tac3d/scene/scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <utility>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

const char* kSlide = R"(
name: slide
sensor: default
deviation: {mesh_refinement: 1.25, youngs_modulus_factor: 1.1}
objects:
  - name: block
    shape: box
    size_mm: [60, 40, 10]
    position_mm: [0, 0, 13.5]
    friction:
      default: 0.4
      regions:
        - {box_min_mm: [-31, -21, -6], box_max_mm: [0, 21, 6], mu: 1.0}
        - {ball_center_mm: [10, 0, -5], ball_radius_mm: 2, mu: 1.5}
trajectory:
  steps: 11
  keyframes:
    - {t_s: 0, position_mm: [-8, 0, 0]}
    - {t_s: 1, position_mm: [-8, 0, 1.3]}
    - {t_s: 5, position_mm: [8, 0, 1.3], rpy_deg: [0, 0, 90]}
)";

std::string SceneErrorOf(const std::string& yaml) {
  try {
    ParseScene(yaml, "test.yaml", "");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(Scene, ParsesObjectsFrictionAndTrajectory) {
  const Scene scene = ParseScene(kSlide, "test.yaml", "");
  EXPECT_EQ(scene.name, "slide");
  EXPECT_DOUBLE_EQ(scene.deviation.mesh_refinement, 1.25);
  EXPECT_DOUBLE_EQ(scene.deviation.youngs_modulus_factor, 1.1);
  EXPECT_DOUBLE_EQ(scene.deviation.poisson_ratio_factor, TwinDeviation{}.poisson_ratio_factor);
  ASSERT_EQ(scene.objects.size(), 1u);
  const SceneObject& block = scene.objects[0];
  EXPECT_EQ(block.shape, SceneObject::Shape::kBox);
  EXPECT_DOUBLE_EQ(block.FrictionAt({-5, 0, -5}), 1.0);   // the rough half
  EXPECT_DOUBLE_EQ(block.FrictionAt({5, 0, -5}), 0.4);    // the smooth half
  EXPECT_DOUBLE_EQ(block.FrictionAt({10.5, 0, -5}), 1.5); // the ball region
  EXPECT_NEAR(block.world_from_object.translation().z(), 13.5, 0);
}

TEST(Scene, DefaultDeviationRefinesTheMeshOneAndAHalfTimes) {
  // 1.5 is the finest refinement of the default dome that the simulation solves directly.
  const Scene scene =
      ParseScene(Replace(kSlide, "deviation: {mesh_refinement: 1.25, youngs_modulus_factor: 1.1}\n", ""),
                 "test.yaml", "");
  EXPECT_DOUBLE_EQ(scene.deviation.mesh_refinement, 1.5);
  EXPECT_DOUBLE_EQ(scene.deviation.youngs_modulus_factor, TwinDeviation{}.youngs_modulus_factor);
}

TEST(Scene, ConditionsAndSpreadAreOptionsWithTheirDefaults) {
  const Scene plain = ParseScene(kSlide, "test.yaml", "");
  EXPECT_EQ(plain.conditions.At(1e9).illumination_gain, 1.0);  // no nuisance by default
  EXPECT_FALSE(plain.spread.has_value());
  const std::string with = Replace(kSlide, "objects:\n",
                                   "conditions: {levels: realistic, creep_mm: 0.05}\n"
                                   "spread: {seed: 4, camera_tilt_max_deg: 0.2}\nobjects:\n");
  const Scene scene = ParseScene(with, "test.yaml", "");
  const SessionConditions realistic = SessionConditions::Realistic();
  EXPECT_DOUBLE_EQ(scene.conditions.illumination_gain, realistic.illumination_gain);
  EXPECT_DOUBLE_EQ(scene.conditions.creep_mm, 0.05);
  ASSERT_TRUE(scene.spread.has_value());
  EXPECT_EQ(scene.spread->seed, 4u);
  EXPECT_DOUBLE_EQ(scene.spread->camera_tilt_max_deg, 0.2);
  EXPECT_DOUBLE_EQ(scene.spread->camera_shift_max_mm,
                   SensorPerturbationOptions::ManufacturingSpread(4).camera_shift_max_mm);
  EXPECT_THAT(SceneErrorOf(Replace(with, "levels: realistic", "levels: harsh")), HasSubstr("conditions.levels"));
  EXPECT_THAT(SceneErrorOf(Replace(with, "creep_mm: 0.05", "creep_mm: -1")), HasSubstr("creep_mm"));
  EXPECT_THAT(SceneErrorOf(Replace(with, "creep_mm: 0.05", "glare: 1")), HasSubstr("unknown key"));
}

TEST(Trajectory, InterpolatesPositionLinearlyAndRotationBySlerp) {
  const Scene scene = ParseScene(kSlide, "test.yaml", "");
  const Trajectory& t = scene.trajectory;
  EXPECT_DOUBLE_EQ(t.StepTime(0), 0.0);
  EXPECT_DOUBLE_EQ(t.StepTime(10), 5.0);
  const Rigid3 mid = t.PoseAt(3.0);  // halfway between the 2nd and 3rd keyframes
  EXPECT_THAT(mid.translation(), EigenNear(Eigen::Vector3d(0, 0, 1.3), 1e-12));
  EXPECT_NEAR(RotationAngleDeg(mid.linear(), Eigen::Matrix3d::Identity()), 45.0, 1e-9);
  EXPECT_THAT(t.PoseAt(-1).translation(), EigenNear(Eigen::Vector3d(-8, 0, 0), 0));
  EXPECT_THAT(t.PoseAt(99).translation(), EigenNear(Eigen::Vector3d(8, 0, 1.3), 1e-12));
}

TEST(Trajectory, TangentialLoadRampsFromItsStartToItsFinalLoad) {
  // Pressed by t = 1 at x = -8, held there while the load ramps.
  const std::string held = Replace(kSlide, "- {t_s: 5, position_mm: [8, 0, 1.3], rpy_deg: [0, 0, 90]}",
                                   "- {t_s: 5, position_mm: [-8, 0, 1.3]}\n"
                                   "  tangential_load: {start_s: 1, rate_per_s: 0.5, final_load: 1.2, direction_deg: 90}");
  const Scene scene = ParseScene(held, "test.yaml", "");
  ASSERT_TRUE(scene.trajectory.tangential_load.has_value());
  const TangentialLoadRamp& load = *scene.trajectory.tangential_load;
  EXPECT_EQ(load.LoadAt(0.5), 0.0);
  EXPECT_DOUBLE_EQ(load.LoadAt(2.0), 0.5);
  EXPECT_DOUBLE_EQ(load.LoadAt(4.0), 1.2);  // capped at final_load from t = 3.4
  EXPECT_THAT(load.Direction(), EigenNear(Eigen::Vector2d(0, 1), 1e-15));
  EXPECT_FALSE(ParseScene(kSlide, "test.yaml", "").trajectory.tangential_load.has_value());
  EXPECT_THAT(SceneErrorOf(Replace(held, "rate_per_s: 0.5", "rate_per_s: 0")),
              HasSubstr("trajectory.tangential_load.rate_per_s = 0 is out of range"));
  EXPECT_THAT(SceneErrorOf(Replace(held, "final_load: 1.2", "final_load: 11")),
              HasSubstr("trajectory.tangential_load.final_load = 11 is out of range"));
  EXPECT_THAT(SceneErrorOf(Replace(held, "start_s: 1", "start_s: 5")),
              HasSubstr("trajectory.tangential_load.start_s = 5 is out of range"));
  EXPECT_THAT(SceneErrorOf(Replace(held, "final_load: 1.2", "final_load: 1.2, speed: 1")),
              HasSubstr("unknown key"));
  // The pose may not move the sensor tangentially under the load: kSlide's own slide is refused.
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "  keyframes:", "  tangential_load: {start_s: 1, rate_per_s: 1, "
                                   "final_load: 1}\n  keyframes:")),
              HasSubstr("trajectory.keyframes[2] (x-y motion"));
}

TEST(Scene, BadValuesNameTheFieldAndTheBound) {
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "default: 0.4", "default: -0.1")), HasSubstr("friction.default"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "shape: box", "shape: torus")), HasSubstr("'torus' is not one of"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "t_s: 5", "t_s: 0.5")), HasSubstr("keyframes[2].t_s"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "steps: 11", "steps: 1")), HasSubstr("trajectory.steps"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "size_mm: [60, 40, 10]", "size_mm: [60, 0, 10]")), HasSubstr("size_mm"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "ball_radius_mm: 2", "ball_radius_mm: 0")), HasSubstr("ball_radius_mm"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "youngs_modulus_factor: 1.1", "poisson_ratio_factor: 1.1")),
              HasSubstr("poisson_ratio_factor"));
  // 1e-200 never ended, 1e-100 gave zero forces: E at a tenth of the sensor's at least.
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "youngs_modulus_factor: 1.1", "youngs_modulus_factor: 1e-200")),
              HasSubstr("deviation.youngs_modulus_factor = 1e-200 is out of range: must be in [0.1, 2]"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "name: block", "name: block\n    colour: red")), HasSubstr("unknown key"));
  EXPECT_THAT(SceneErrorOf(Replace(kSlide, "sensor: default", "sensor: nowhere.yaml")), HasSubstr("nowhere.yaml"));
  EXPECT_THAT(SceneErrorOf("name: [unclosed"), HasSubstr("not valid YAML"));
}

TEST(Scene, MeshObjectWithPerVertexFrictionAndCsvTrajectory) {
  const std::string dir = testing::MakeTempDir("scene_mesh");
  TriangleMesh mesh;
  mesh.vertices = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  mesh.vertex_properties["mu"] = {0.2, 0.4, 0.6, 0.8};
  WritePly(mesh, dir + "/plate.ply");
  std::ofstream(dir + "/poses.csv") << "# a press\nt_s, x_mm, y_mm, z_mm, roll_deg, pitch_deg, yaw_deg\n"
                                       "0,0,0,0,0,0,0\n1,0,0,1,0,0,0\n2,0,0,0,0,0,0\n";
  std::ofstream(dir + "/scene.yaml") << R"(
name: plate
objects:
  - {name: plate, shape: mesh, ply: plate.ply, position_mm: [0, 0, 8.5],
     friction: {default: 0.5, vertex_property: mu}}
trajectory: {steps: 21, csv: poses.csv}
)";
  const Scene scene = LoadScene(dir + "/scene.yaml");
  const SceneObject& plate = scene.objects[0];
  EXPECT_DOUBLE_EQ(plate.FrictionAt({9, 9, 0}), 0.6);     // nearest vertex (10, 10, 0)
  EXPECT_DOUBLE_EQ(plate.FrictionAt({-9.5, 8, 3}), 0.8);  // nearest vertex (-10, 10, 0)
  EXPECT_EQ(scene.trajectory.keyframes.size(), 3u);
  EXPECT_NEAR(scene.trajectory.PoseAt(0.5).translation().z(), 0.5, 1e-12);

  std::ofstream(dir + "/bad.csv") << "t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,0,0,0,0,0\n";
  try {
    ReadTrajectoryCsv(dir + "/bad.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("bad.csv:2"));
  }
}

// Issue 22, defect 8 (the pose readers' sibling): a device or a folder as the trajectory CSV is
// refused before a byte is read.
TEST(Scene, TrajectoryCsvThatIsNotARegularFileIsRefused) {
  EXPECT_THAT([] { ReadTrajectoryCsv("/dev/zero"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("'/dev/zero' is not a regular file")));
  EXPECT_THAT([] { ReadTrajectoryCsv(testing::MakeTempDir("trajectory_folder")); },
              ::testing::ThrowsMessage<Error>(HasSubstr("is a directory, not a file")));
}

TEST(IndexedMesh, NearestVertexAgreesWithBruteForce) {
  TriangleMesh mesh;
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> u(-20, 20);
  for (int i = 0; i < 2000; ++i) mesh.vertices.emplace_back(u(rng), u(rng), 0.1 * u(rng));
  const IndexedMesh indexed(mesh);
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d p(1.5 * u(rng), 1.5 * u(rng), u(rng));
    int best = 0;
    for (int i = 1; i < 2000; ++i) {
      if ((mesh.vertices[i] - p).squaredNorm() < (mesh.vertices[best] - p).squaredNorm()) best = i;
    }
    EXPECT_DOUBLE_EQ((mesh.vertices[indexed.NearestVertex(p)] - p).norm(), (mesh.vertices[best] - p).norm());
  }
}

// A triangle's nearest point by brute force: the nearest of its plane's projection (when
// inside) and of the points on its three edges (dense samples, refined near the best).
Eigen::Vector3d BruteClosestOnTriangle(const Eigen::Vector3d& p,
                                       const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  Eigen::Matrix3d basis;
  basis << b - a, c - a, (b - a).cross(c - a);
  const Eigen::Vector3d w = basis.inverse() * (p - a);  // p = a + w0 ab + w1 ac + w2 n
  if (w[0] >= 0 && w[1] >= 0 && w[0] + w[1] <= 1) return a + w[0] * (b - a) + w[1] * (c - a);
  Eigen::Vector3d best = a;
  for (const auto& [from, to] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
    const double s = std::clamp((p - from).dot(to - from) / (to - from).squaredNorm(), 0.0, 1.0);
    const Eigen::Vector3d q = from + s * (to - from);
    if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
  }
  return best;
}

TEST(IndexedMesh, ClosestSurfacePointAgreesWithBruteForce) {
  // Triangles of mixed sizes (0.2 to 8 mm) scattered in a 40 mm box, so that the nearest one
  // is often listed far from the query's cell.
  TriangleMesh mesh;
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> u(-20, 20), unit(-1, 1), size(0.2, 8.0);
  for (int t = 0; t < 400; ++t) {
    const Eigen::Vector3d centre(u(rng), u(rng), 0.2 * u(rng));
    const double s = size(rng);
    for (int k = 0; k < 3; ++k)
      mesh.vertices.push_back(centre + s * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
    mesh.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
  }
  const IndexedMesh indexed(mesh);
  ASSERT_TRUE(indexed.has_surface());
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d p(1.5 * u(rng), 1.5 * u(rng), u(rng));  // some outside the mesh's box
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3i& t : mesh.triangles) {
      best = std::min(best,
                      (BruteClosestOnTriangle(
                           p, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]) -
                       p)
                          .norm());
    }
    EXPECT_NEAR((indexed.ClosestSurfacePoint(p) - p).norm(), best, 1e-9) << p.transpose();
  }
}

TEST(IndexedMesh, DegenerateTrianglesAreNoSurface) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}, {1, 1, 3}};  // collinear; two corners the same vertex
  const IndexedMesh line(mesh);
  EXPECT_FALSE(line.has_surface());
  EXPECT_THAT(
      [&] {
        line.ClosestSurfacePoint({0, 0, 1});
      },
      ::testing::ThrowsMessage<Error>(HasSubstr("no triangle with an area")));
  mesh.triangles.push_back({0, 1, 3});  // one with an area: the surface
  const IndexedMesh one(mesh);
  EXPECT_THAT(one.ClosestSurfacePoint({2, 0, 1}), EigenNear(Eigen::Vector3d(1, 0, 0), 1e-12));
  mesh.triangles.push_back({0, 1, 4});
  EXPECT_THAT(
      [&] { IndexedMesh bad(mesh); },
      ::testing::ThrowsMessage<Error>(HasSubstr("triangle 3 indexes a vertex out of 0..3")));
}

// Each built-in scene is valid and does what its description says.
TEST(BuiltInScenes, AreValidAndTouchTheirObjects) {
  for (const std::string& name : BuiltInSceneNames()) {
    SCOPED_TRACE(name);
    const Scene scene = BuiltInScene(name);
    EXPECT_EQ(scene.name, name);
    EXPECT_NO_THROW(scene.Validate());
    // The lead-in: the first 25 steps hold the first pose, so the pipeline's 20 reference
    // frames see the sensor at rest; the 26th has started to move.
    const Trajectory& t = scene.trajectory;
    for (int k = 1; k < 25; ++k) {
      EXPECT_TRUE(t.PoseAt(t.StepTime(k)).isApprox(t.PoseAt(0.0), 1e-12)) << k;
    }
    EXPECT_FALSE(t.PoseAt(t.StepTime(26)).isApprox(t.PoseAt(0.0), 1e-9));
  }
  EXPECT_EQ(BuiltInScene("two_material_slide").trajectory.steps, 525);
  const Scene slide = BuiltInScene("two_material_slide");
  EXPECT_DOUBLE_EQ(slide.objects[0].FrictionAt({-5, 0, -5}), 1.0);
  EXPECT_DOUBLE_EQ(slide.objects[0].FrictionAt({5, 0, -5}), 0.4);
  // The bottle: at the middle of the slide (phi = 10 deg) the fingertip's top is pressed
  // 0.3 mm into the cylinder; the rubber disc is where the fingertip is at phi = 20 deg.
  const Scene bottle = BuiltInScene("bottle");
  const SceneObject& cylinder = bottle.objects[0];
  const double lead_in_s = bottle.trajectory.keyframes[1].t_s;
  const Rigid3 world_from_sensor = bottle.trajectory.PoseAt(lead_in_s + 5.0);
  const Eigen::Vector3d tip_world = world_from_sensor * Eigen::Vector3d(0, 0, 8.0);
  const Eigen::Vector3d tip_object = cylinder.world_from_object.inverse() * tip_world;
  EXPECT_NEAR(30.0 - std::hypot(tip_object.x(), tip_object.z()), 0.3, 1e-9);
  const double phi = 20.0 * M_PI / 180.0;
  EXPECT_DOUBLE_EQ(cylinder.FrictionAt({-30 * std::sin(phi), 0, -30 * std::cos(phi)}), 1.2);
  EXPECT_DOUBLE_EQ(cylinder.FrictionAt({0, 0, -30}), 0.3);
  EXPECT_THAT(SceneErrorOf("name: x"), HasSubstr("objects"));
  EXPECT_THROW(BuiltInScene("nope"), Error);
}

// The friction-map scenes: three strokes each, pressed 0.3 mm (the fingertip's top point in
// the object), lifted clear in between, each at its own offset along the strokes' normal, so
// no stroke drags across another; the materials in the paper's bands.
TEST(BuiltInScenes, FrictionScenesStrokeInThreeLiftedPasses) {
  for (const std::string name :
       {"friction_block", "friction_bottle", "friction_paint_can", "friction_tool_handle"}) {
    SCOPED_TRACE(name);
    const Scene scene = BuiltInScene(name);
    const SceneObject& object = scene.objects[0];
    const Trajectory& t = scene.trajectory;
    std::vector<double> offsets;  // y of each pressed segment
    bool pressed = false;
    double max_depth = -1e9;
    for (int k = 0; k < t.steps; ++k) {
      const Rigid3 pose = t.PoseAt(t.StepTime(k));
      const Eigen::Vector3d tip = object.world_from_object.inverse() * (pose * Eigen::Vector3d(0, 0, 8.0));
      const double depth = object.shape == SceneObject::Shape::kBox
                               ? tip.z() + 0.5 * object.size_mm.z()
                               : object.radius_mm - std::hypot(tip.x(), tip.z());
      max_depth = std::max(max_depth, depth);
      if (depth > 0 && !pressed) offsets.push_back(tip.y());
      if (depth > 0) {
        EXPECT_NEAR(tip.y(), offsets.back(), 1e-9) << k;
      }
      pressed = depth > 0;
    }
    EXPECT_NEAR(max_depth, 0.3, 0.002);  // chords between the cylinders' keyframes: 0.0018 mm
    ASSERT_EQ(offsets.size(), 3u);
    EXPECT_GT(offsets[1] - offsets[0], 4.0);
    EXPECT_GT(offsets[2] - offsets[1], 4.0);
  }
  const SceneObject can = BuiltInScene("friction_paint_can").objects[0];
  const auto at = [](double phi_deg, double y) {
    const double phi = phi_deg * M_PI / 180.0;
    return Eigen::Vector3d(-40 * std::sin(phi), y, -40 * std::cos(phi));
  };
  EXPECT_DOUBLE_EQ(can.FrictionAt(at(0, 0)), 0.65);    // paint: green
  EXPECT_DOUBLE_EQ(can.FrictionAt(at(0, -8)), 1.0);    // tape: red
  EXPECT_DOUBLE_EQ(can.FrictionAt(at(15, 5)), 0.35);   // sticker: blue
  EXPECT_DOUBLE_EQ(can.FrictionAt(at(-10, 5)), 0.65);  // paint the other side of the can
  const SceneObject handle = BuiltInScene("friction_tool_handle").objects[0];
  const auto on_handle = [](double phi_deg, double y) {
    const double phi = phi_deg * M_PI / 180.0;
    return Eigen::Vector3d(-16 * std::sin(phi), y, -16 * std::cos(phi));
  };
  EXPECT_DOUBLE_EQ(handle.FrictionAt(on_handle(0, 0)), 0.45);   // plastic: blue
  EXPECT_DOUBLE_EQ(handle.FrictionAt(on_handle(10, -6)), 1.1);  // rubber grip: red
  EXPECT_DOUBLE_EQ(handle.FrictionAt(on_handle(10, 6)), 0.7);   // label: green
  EXPECT_DOUBLE_EQ(handle.FrictionAt(on_handle(-5, 6)), 0.45);  // plastic beside the label
  EXPECT_DOUBLE_EQ(handle.FrictionAt(on_handle(25, 6)), 0.45);
  const SceneObject block = BuiltInScene("friction_block").objects[0];
  EXPECT_DOUBLE_EQ(block.FrictionAt({-5, 3, -5}), 1.0);
  EXPECT_DOUBLE_EQ(block.FrictionAt({5, 3, -5}), 0.4);
}

TEST(Scene, FlatPunchEdgeRadiusIsOptionalAndBounded) {
  const std::string punch = Replace(kSlide, "shape: box\n    size_mm: [60, 40, 10]", "shape: flat_punch\n    radius_mm: 2");
  EXPECT_DOUBLE_EQ(ParseScene(punch, "test.yaml", "").objects[0].edge_radius_mm, 0.0);
  const std::string rounded = Replace(punch, "radius_mm: 2", "radius_mm: 2\n    edge_radius_mm: 0.5");
  EXPECT_DOUBLE_EQ(ParseScene(rounded, "test.yaml", "").objects[0].edge_radius_mm, 0.5);
  EXPECT_THAT(SceneErrorOf(Replace(punch, "radius_mm: 2", "radius_mm: 2\n    edge_radius_mm: 2.5")),
              HasSubstr("edge_radius_mm = 2.5 is out of range: must be in [0, radius_mm]"));
}

// The incipient-slip family: 36 distinct scenes, each named as it is built and parsed back;
// pressed, held, then slid along +x by 3 mu depth + 0.1 mm at constant speed.
TEST(IncipientScenes, FamilyNamesRoundTripAndTheRampSlides) {
  const std::vector<IncipientSceneSpec> family = IncipientSceneFamily();
  ASSERT_EQ(family.size(), 36u);
  std::set<std::string> names;
  for (const IncipientSceneSpec& spec : family) {
    SCOPED_TRACE(spec.Name());
    names.insert(spec.Name());
    const std::optional<IncipientSceneSpec> parsed = ParseIncipientSceneName(spec.Name());
    ASSERT_TRUE(parsed);
    EXPECT_EQ(parsed->Name(), spec.Name());
    const Scene scene = LoadSceneOrBuiltIn(spec.Name());
    EXPECT_EQ(scene.name, spec.Name());
    EXPECT_DOUBLE_EQ(scene.objects[0].friction.default_mu, spec.mu);
    const Trajectory& t = scene.trajectory;
    // 25 lead-in frames, 15 pressing, 6 holding, the ramp's frames at 60 Hz.
    EXPECT_EQ(t.steps, 25 + 15 + 6 + (spec.ramp == IncipientSceneSpec::Ramp::kSlow ? 120 : 30) + 1);
    EXPECT_NEAR(t.StepTime(1) - t.StepTime(0), 1.0 / 60.0, 1e-12);
    const Eigen::Vector3d end = t.PoseAt(t.StepTime(t.steps - 1)).translation();
    EXPECT_NEAR(end.x(), 3.0 * spec.mu * spec.depth_mm() + 0.1, 1e-12);
    EXPECT_NEAR(end.z(), 0.5 + spec.depth_mm(), 1e-12);
    // Constant speed over the ramp: halfway through it, half the slide.
    const double ramp_start = t.StepTime(25 + 15 + 6), ramp_end = t.StepTime(t.steps - 1);
    EXPECT_NEAR(t.PoseAt(0.5 * (ramp_start + ramp_end)).translation().x(), 0.5 * end.x(), 1e-9);
    EXPECT_NEAR(t.PoseAt(ramp_start).translation().x(), 0.0, 1e-12);
    EXPECT_NEAR(ramp_start, spec.ramp_start_s(), 1e-9);
  }
  EXPECT_EQ(names.size(), 36u);
  const Scene punch = BuiltInScene("incipient_punch_mu0.3_heavy_fast_15hz");
  EXPECT_EQ(punch.objects[0].shape, SceneObject::Shape::kFlatPunch);
  EXPECT_DOUBLE_EQ(punch.objects[0].edge_radius_mm, 0.75);
  EXPECT_EQ(punch.trajectory.steps, 25 + 4 + 2 + 8 + 1);  // 0.25 s, 0.1 s, 0.5 s at 15 Hz
}

TEST(IncipientScenes, BadNamesAndSpecsAreRefused) {
  for (const std::string name : {"incipient_cone_mu0.3_light_slow", "incipient_sphere_mux_light_slow",
                                 "incipient_sphere_mu0.3_medium_slow", "incipient_sphere_mu0.3_light_slow_15",
                                 "incipient_sphere_mu0.3_light", "sphere_mu0.3_light_slow"}) {
    EXPECT_FALSE(ParseIncipientSceneName(name)) << name;
  }
  EXPECT_THAT([] { BuiltInScene("incipient_cone_mu0.3_light_slow"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("incipient_<sphere|cylinder|punch>")));
  EXPECT_THAT([] { BuiltInScene("incipient_sphere_mu2.5_light_slow"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("mu must be in (0, 2], got 2.5")));
  EXPECT_THAT([] { BuiltInScene("incipient_sphere_mu0.3_light_slow_2hz"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("frame_rate_hz must be in [5, 1000], got 2")));
}

}  // namespace
}  // namespace tac3d
