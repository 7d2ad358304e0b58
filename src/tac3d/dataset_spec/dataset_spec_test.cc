#include "tac3d/dataset_spec/dataset_spec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>

#include "tac3d/scene/ply.h"
#include "tac3d/scene/scene.h"
#include "tac3d/sensor/test_yaml_mutator.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

const char* kMixedSpec = R"(name: mixed
seed: 11
sensor: default
steps: 20
images: false
twin: {mesh_refinement: 1.0, margin_mm: 0.8, quadrature_points_per_side: 2}
sensor_conditions:
  youngs_modulus_factor: {choice: [0.9, 1.0, 1.1]}
  poisson_ratio_factor: 1.0
  illumination_gain: {uniform: [0.9, 1.1]}
  creep_mm: {uniform: [0, 0.01]}
objects:
  - {shape: sphere, weight: 2, radius_mm: {uniform: [3, 6]}}
  - {shape: cylinder, radius_mm: {uniform: [10, 30]}, length_mm: 40, yaw_deg: {uniform: [0, 180]}}
  - {shape: flat_punch, radius_mm: {choice: [1, 2]}}
  - {shape: pins, radius_mm: 0.5, pitch_mm: 2.54, rows: {choice: [1, 3]}, cols: 3}
  - {shape: box, size_x_mm: 20, size_y_mm: {uniform: [10, 20]}, size_z_mm: 10}
friction:
  mu: {uniform: [0.2, 1.2]}
  regions: {count: {choice: [0, 1, 2]}, mu: {uniform: [0.3, 1.5]}, radius_mm: 1.5, offset_mm: 1}
trajectories:
  - {kind: press, depth_mm: {uniform: [0.05, 0.2]}, speed_mm_s: 1}
  - {kind: slide, depth_mm: 0.1, distance_mm: {uniform: [0.2, 1]}, direction_deg: {uniform: [0, 360]}, speed_mm_s: 2}
  - {kind: twist, depth_mm: 0.1, speed_mm_s: 1, angle_deg: {uniform: [-10, 10]}, angular_speed_deg_s: 10}
  - {kind: lift, depth_mm: 0.1, speed_mm_s: 1}
  - {kind: load_ramp, depth_mm: {uniform: [0.05, 0.2]}, speed_mm_s: 1, rate_per_s: {uniform: [0.5, 2]}, final_load: {uniform: [1.1, 1.5]}, direction_deg: {uniform: [0, 360]}}
)";

DatasetSpec MixedSpec(const std::string& text = kMixedSpec) {
  return ParseDatasetSpec(text, "spec.yaml", ".");
}

std::string DatasetSpecErrorOf(const std::string& text) {
  try {
    MixedSpec(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

std::string ReplacedInSpec(const std::string& text,
                           const std::string& from,
                           const std::string& to) {
  const std::string out = std::regex_replace(text, std::regex(from), to);
  EXPECT_NE(out, text) << from;
  return out;
}

TEST(DatasetSpec, ParsesEveryFamily) {
  const DatasetSpec spec = MixedSpec();
  EXPECT_EQ(spec.name, "mixed");
  EXPECT_EQ(spec.seed, 11u);
  EXPECT_EQ(spec.steps, 20);
  EXPECT_FALSE(spec.images);
  EXPECT_FALSE(spec.measured);  // unless asked for
  EXPECT_TRUE(MixedSpec(ReplacedInSpec(kMixedSpec, "images: false", "images: false\nmeasured: true")).measured);
  EXPECT_EQ(spec.objects.size(), 5u);
  EXPECT_EQ(spec.trajectories.size(), 5u);
  EXPECT_EQ(spec.objects[0].weight, 2.0);
  EXPECT_EQ(spec.objects[0].sizes.at("radius_mm").kind, Distribution::Kind::kUniform);
  EXPECT_EQ(spec.twin_options.at("margin_mm"), 0.8);
  EXPECT_EQ(spec.youngs_modulus_factor.values, (std::vector<double>{0.9, 1.0, 1.1}));
  EXPECT_EQ(spec.conditions.size(), 2u);
  EXPECT_EQ(spec.fingertip_top_mm, 8.0);
}

TEST(DatasetSpec, EpisodeDrawsDependOnlyOnSeedAndIndex) {
  const DatasetSpec spec = MixedSpec();
  const EpisodeDraw a = DrawEpisode(spec, 7);
  DrawEpisode(spec, 3);  // no state carried between draws
  EXPECT_EQ(DrawEpisode(spec, 7).scene_yaml, a.scene_yaml);
  EXPECT_EQ(a.seed, EpisodeSeed(11, 7));
  EXPECT_NE(DrawEpisode(spec, 8).scene_yaml, a.scene_yaml);
  DatasetSpec reseeded = spec;
  reseeded.seed = 12;
  EXPECT_NE(DrawEpisode(reseeded, 7).scene_yaml, a.scene_yaml);
  EXPECT_THROW(DrawEpisode(spec, -1), Error);
}

TEST(DatasetSpec, DrawsStayInTheirRangesAndEverySceneIsValid) {
  const DatasetSpec spec = MixedSpec();
  std::set<std::string> shapes, kinds;
  std::set<double> youngs;
  for (int i = 0; i < 200; ++i) {
    const EpisodeDraw draw = DrawEpisode(spec, i);
    const Scene scene = ParseScene(draw.scene_yaml, "episode", ".");
    const nlohmann::json& p = draw.parameters;
    shapes.insert(p["object"]["shape"].get<std::string>());
    kinds.insert(p["trajectory"]["kind"].get<std::string>());
    youngs.insert(p["sensor"]["youngs_modulus_factor"].get<double>());
    const double mu = p["friction"]["mu"];
    EXPECT_GE(mu, 0.2);
    EXPECT_LE(mu, 1.2);
    EXPECT_LE(p["friction"]["regions"].size(), 2u);
    const double gain = p["sensor"]["conditions"]["illumination_gain"];
    EXPECT_GE(gain, 0.9);
    EXPECT_LE(gain, 1.1);
    ASSERT_EQ(scene.objects.size(), 1u);
    EXPECT_EQ(scene.trajectory.steps, 20);
    EXPECT_EQ(scene.deviation.youngs_modulus_factor,
              p["sensor"]["youngs_modulus_factor"].get<double>());
    // Every episode starts clear of the object and ends pressed (or lifted back out).
    const double depth = p["trajectory"]["depth_mm"];
    EXPECT_NEAR(scene.trajectory.PoseAt(0).translation().z(), 0.0, 1e-12);
    const double end_z = scene.trajectory.PoseAt(scene.trajectory.duration_s()).translation().z();
    EXPECT_NEAR(end_z, p["trajectory"]["kind"] == "lift" ? 0.0 : 0.05 + depth, 1e-12);
    // A load ramp: pressed in at t_in, then held while the load rises to final_load.
    const std::optional<TangentialLoadRamp>& load = scene.trajectory.tangential_load;
    ASSERT_EQ(load.has_value(), p["trajectory"]["kind"] == "load_ramp");
    if (load) {
      const nlohmann::json& t = p["trajectory"];
      EXPECT_GE(load->rate_per_s, 0.5);
      EXPECT_LE(load->rate_per_s, 2.0);
      EXPECT_GE(load->final_load, 1.1);
      EXPECT_LE(load->final_load, 1.5);
      EXPECT_EQ(load->direction_deg, t["direction_deg"].get<double>());
      EXPECT_DOUBLE_EQ(load->start_s, (0.05 + depth) / 1.0);
      EXPECT_DOUBLE_EQ(scene.trajectory.duration_s(), load->start_s + load->final_load / load->rate_per_s);
      EXPECT_DOUBLE_EQ(load->LoadAt(scene.trajectory.duration_s()), t["final_load"].get<double>());
    }
    if (p["object"]["shape"] == "sphere") {
      const double r = p["object"]["radius_mm"];
      EXPECT_GE(r, 3.0);
      EXPECT_LE(r, 6.0);
      EXPECT_NEAR(scene.objects[0].world_from_object.translation().z(), 8.0 + 0.05 + r, 1e-12);
    }
  }
  EXPECT_EQ(shapes, (std::set<std::string>{"sphere", "cylinder", "flat_punch", "pins", "box"}));
  EXPECT_EQ(kinds, (std::set<std::string>{"press", "slide", "twist", "lift", "load_ramp"}));
  EXPECT_EQ(youngs, (std::set<double>{0.9, 1.0, 1.1}));
}

TEST(DatasetSpec, MeshFamilyDrawsAPlyOfTheFolderAndRestsItOnItsLowestVertex) {
  const std::string dir = testing::MakeTempDir("dataset_spec_mesh");
  std::filesystem::create_directories(dir + "/meshes");
  TriangleMesh mesh;
  mesh.vertices = {{-2, -2, -1.5}, {2, -2, -1.5}, {0, 2, -1.5}, {0, 0, 3}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  WritePly(mesh, dir + "/meshes/tetra.ply");
  const std::string text =
      ReplacedInSpec(kMixedSpec, "  - \\{shape: sphere.*\n", "  - {shape: mesh, folder: meshes}\n");
  { std::ofstream(dir + "/spec.yaml") << text; }
  const DatasetSpec spec = LoadDatasetSpec(dir + "/spec.yaml");
  ASSERT_EQ(spec.objects[0].ply_files.size(), 1u);
  for (int i = 0; i < 40; ++i) {
    const EpisodeDraw draw = DrawEpisode(spec, i);
    if (draw.parameters["object"]["shape"] != "mesh") continue;
    EXPECT_EQ(draw.parameters["object"]["ply"], "tetra.ply");
    const Scene scene = ParseScene(draw.scene_yaml, "episode", ".");
    EXPECT_NEAR(scene.objects[0].world_from_object.translation().z(), 8.0 + 0.05 + 1.5, 1e-12);
    return;
  }
  FAIL() << "no mesh drawn in 40 episodes";
}

TEST(DatasetSpec, RefusesBadInputNamingTheLine) {
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "steps: 20", "steps: 20\nsteps: 30")),
            "spec.yaml: line 5: duplicated key 'steps' (first at line 4)");
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "images: false", "image: false")),
            "spec.yaml: line 5: image: unknown key (misspelt?)");
  EXPECT_THAT(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "images: false", "images: false\nmeasured: often")),
              HasSubstr("spec.yaml: line 6: measured"));
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(
                kMixedSpec, "mu: \\{uniform: \\[0.2, 1.2\\]\\}", "mu: {uniform: [0.2, 7]}")),
            "spec.yaml: line 19: friction.mu.uniform[1]: 7 is out of range: must be in [0, 5]");
  EXPECT_EQ(
      DatasetSpecErrorOf(ReplacedInSpec(
          kMixedSpec, "radius_mm: \\{uniform: \\[3, 6\\]\\}", "radius_mm: {uniform: [6, 3]}")),
      "spec.yaml: line 13: objects[0].radius_mm.uniform: must be [low, high] with low <= high");
  EXPECT_EQ(
      DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "shape: box", "shape: torus")),
      "spec.yaml: line 17: objects[4].shape: 'torus' is not one of sphere, cylinder, flat_punch, "
      "pins, box, mesh");
  EXPECT_EQ(
      DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "kind: lift", "kind: hover")),
      "spec.yaml: line 25: trajectories[3].kind: 'hover' is not one of press, slide, twist, lift, "
      "load_ramp");
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "final_load: \\{uniform: \\[1.1, 1.5\\]\\}",
                                              "final_load: {uniform: [1.1, 11]}")),
            "spec.yaml: line 26: trajectories[4].final_load.uniform[1]: 11 is out of range: must be in "
            "(0, 10]");
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "rate_per_s: \\{uniform: \\[0.5, 2\\]\\}, ", "")),
            "spec.yaml: line 26: trajectories[4].rate_per_s: missing");
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(
                kMixedSpec, "rows: \\{choice: \\[1, 3\\]\\}", "rows: {uniform: [1, 3]}")),
            "spec.yaml: line 16: objects[3].rows.uniform: an integer is drawn with choice");
  EXPECT_EQ(
      DatasetSpecErrorOf(
          ReplacedInSpec(kMixedSpec, "rows: \\{choice: \\[1, 3\\]\\}", "rows: {choice: [1.5]}")),
      "spec.yaml: line 16: objects[3].rows.choice[0]: 1.5 is out of range: must be in [1, 20], an "
      "integer");
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(
                kMixedSpec, "  - \\{kind: press.*\n", "  - {kind: press, speed_mm_s: 1}\n")),
            "spec.yaml: line 22: trajectories[0].depth_mm: missing");
  EXPECT_EQ(
      DatasetSpecErrorOf(ReplacedInSpec(
          kMixedSpec, "creep_mm: \\{uniform: \\[0, 0.01\\]\\}", "creep_mm: {uniform: [0, x]}")),
      "spec.yaml: line 11: sensor_conditions.creep_mm.uniform[1]: must be a number");
  EXPECT_THAT(
      DatasetSpecErrorOf(
          ReplacedInSpec(kMixedSpec, "poisson_ratio_factor: 1.0", "poisson_ratio_factor: 1.1")),
      HasSubstr("spec.yaml: line 9: sensor_conditions.poisson_ratio_factor: 1.1 is out of range"));
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec,
                                              "poisson_ratio_factor: 1.0",
                                              "poisson_ratio_factor: {uniform: [0.9, 1.0]}")),
            "spec.yaml: line 9: sensor_conditions.poisson_ratio_factor: each value is a body "
            "model: draw it with choice, not uniform");
  // Far below a tenth of E the solver's tolerance swallowed the forces, or it never ended.
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec,
                                              "youngs_modulus_factor: \\{choice: \\[0.9, 1.0, 1.1\\]\\}",
                                              "youngs_modulus_factor: 1e-200")),
            "spec.yaml: line 8: sensor_conditions.youngs_modulus_factor: 1e-200 is out of range: must "
            "be in [0.1, 2]");
  // An episode is held and stored whole: its steps are bounded by what fits.
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "steps: 20", "steps: 10001")),
            "spec.yaml: line 4: steps: must be in [2, 10000]");
  // An integer past an int's range is out of range, not "not an integer".
  EXPECT_EQ(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "steps: 20", "steps: 1000000000000")),
            "spec.yaml: line 4: steps: 1000000000000 is out of range: must be an integer in "
            "[-2147483648, 2147483647]");
  EXPECT_THAT(DatasetSpecErrorOf(ReplacedInSpec(kMixedSpec, "seed: 11", "seed: -1")),
              HasSubstr("line 2: seed: must be >= 0"));
  EXPECT_THAT(DatasetSpecErrorOf(ReplacedInSpec(
                  kMixedSpec, "  - \\{shape: sphere.*\n", "  - {shape: mesh, folder: nowhere}\n")),
              HasSubstr("line 13: objects[0].folder: '"));
}

// Seeded fuzzing, as of the run file: a mutated spec parses or throws tac3d::Error (naming
// its line), never a crash, a hang or an allocation without bound.
TEST(DatasetSpecFuzz, AMutatedSpecParsesOrThrowsError) {
  const testing::FuzzCounts counts = testing::FuzzYamlReader(
      kMixedSpec, [](const std::string& text) { ParseDatasetSpec(text, "fuzz.yaml", "."); }, "dataset specs");
  EXPECT_GT(counts.iterations, 500) << "too few iterations in the time bound: a slow path?";
  EXPECT_GT(counts.refused, counts.iterations / 4);
  EXPECT_GT(counts.loaded, 0);
}

}  // namespace
}  // namespace tac3d
