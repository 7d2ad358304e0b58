#include "tac3d/dataset_spec/dataset_spec.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "tac3d/scene/ply.h"
#include "tac3d/scene/scene.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

std::uint64_t SplitMix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// The closed or half-open interval a distribution's values must lie in.
struct Bound {
  double low;
  double high;
  bool low_open = false;
  bool integer = false;

  bool Contains(double v) const {
    return std::isfinite(v) && (low_open ? v > low : v >= low) && v <= high &&
           (!integer || v == std::floor(v));
  }
  std::string Text() const {
    return fmt::format(
        "{}{}, {}]{}", low_open ? "(" : "[", low, high, integer ? ", an integer" : "");
  }
};

const Bound kPositiveMm{0.0, 500.0, true};
constexpr int kMaxEpisodeSteps = 10000;
const Bound kMu{0.0, 5.0};
const Bound kSpeed{0.0, 1000.0, true};

double DrawnValue(const YamlReader& r,
                  const YAML::Node& n,
                  const std::string& where,
                  const Bound& bound) {
  double v = 0.0;
  try {
    if (!n.IsScalar()) throw YAML::Exception(YAML::Mark::null_mark(), "");
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    r.FailAt(n, where, "must be a number");
  }
  if (!bound.Contains(v))
    r.FailAt(n, where, fmt::format("{} is out of range: must be in {}", v, bound.Text()));
  return v;
}

// `key: 0.3`, `key: {uniform: [low, high]}` or `key: {choice: [a, b, ...]}`, every value within
// `bound`, each error naming the line.
Distribution ReadDistribution(YamlReader& r, const std::string& key, const Bound& bound) {
  const YAML::Node n = r.Required(key);
  const std::string where = r.Join(key);
  if (n.IsScalar()) return Distribution::Constant(DrawnValue(r, n, where, bound));
  if (!n.IsMap())
    r.FailAt(n, where, "must be a number, {uniform: [low, high]} or {choice: [values]}");
  YamlReader d(n, where, &r.source());
  Distribution out;
  const bool uniform = d.Has("uniform");
  const std::string kind = uniform ? "uniform" : "choice";
  if (uniform == d.Has("choice")) d.FailAt(n, where, "needs exactly one of uniform and choice");
  const YAML::Node values = d.Sequence(kind);
  out.kind = uniform ? Distribution::Kind::kUniform : Distribution::Kind::kChoice;
  out.values.clear();
  for (size_t i = 0; i < values.size(); ++i) {
    out.values.push_back(DrawnValue(d, values[i], fmt::format("{}.{}[{}]", where, kind, i), bound));
  }
  if (uniform && (values.size() != 2 || out.values[0] > out.values[1])) {
    d.FailAt(values, d.Join(kind), "must be [low, high] with low <= high");
  }
  if (uniform && bound.integer) d.FailAt(values, d.Join(kind), "an integer is drawn with choice");
  if (!uniform && values.size() == 0)
    d.FailAt(values, d.Join(kind), "must list at least one value");
  return out;
}

Distribution ReadDistribution(YamlReader& r,
                              const std::string& key,
                              const Bound& bound,
                              double fallback) {
  return r.Has(key) ? ReadDistribution(r, key, bound) : Distribution::Constant(fallback);
}

double ReadWeight(YamlReader& r) {
  const double w = r.Double("weight", 1.0);
  if (!(w > 0.0 && std::isfinite(w)))
    r.FailAt(r.Required("weight"), r.Join("weight"), "must be > 0");
  return w;
}

// The size keys each shape needs, with their bounds.
const std::map<std::string, std::vector<std::pair<std::string, Bound>>>& ShapeSizes() {
  static const auto* sizes = new std::map<std::string, std::vector<std::pair<std::string, Bound>>>{
      {"sphere", {{"radius_mm", kPositiveMm}}},
      {"cylinder", {{"radius_mm", kPositiveMm}, {"length_mm", kPositiveMm}}},
      {"flat_punch", {{"radius_mm", kPositiveMm}}},
      {"pins",
       {{"radius_mm", kPositiveMm},
        {"pitch_mm", kPositiveMm},
        {"rows", Bound{1, 20, false, true}},
        {"cols", Bound{1, 20, false, true}}}},
      {"box", {{"size_x_mm", kPositiveMm}, {"size_y_mm", kPositiveMm}, {"size_z_mm", kPositiveMm}}},
      {"mesh", {}},
  };
  return *sizes;
}

ObjectFamily ReadObjectFamily(YamlReader r, const std::string& base_dir) {
  ObjectFamily f;
  f.shape = r.String("shape");
  const auto shape = ShapeSizes().find(f.shape);
  if (shape == ShapeSizes().end()) {
    r.FailAt(
        r.Required("shape"),
        r.Join("shape"),
        fmt::format("'{}' is not one of sphere, cylinder, flat_punch, pins, box, mesh", f.shape));
  }
  f.weight = ReadWeight(r);
  for (const auto& [key, bound] : shape->second) f.sizes[key] = ReadDistribution(r, key, bound);
  f.yaw_deg = ReadDistribution(r, "yaw_deg", Bound{-360, 360}, 0.0);
  if (f.shape == "mesh") {
    const std::string folder = r.String("folder");
    const fs::path dir =
        fs::path(folder).is_absolute() ? fs::path(folder) : fs::path(base_dir) / folder;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (entry.path().extension() == ".ply")
        f.ply_files.push_back(fs::absolute(entry.path()).string());
    }
    std::sort(f.ply_files.begin(), f.ply_files.end());
    if (f.ply_files.empty()) {
      r.FailAt(r.Required("folder"),
               r.Join("folder"),
               fmt::format("'{}' {}",
                           dir.string(),
                           ec ? "cannot be listed: " + ec.message() : "holds no .ply file"));
    }
  }
  return f;
}

TrajectoryFamily ReadTrajectoryFamily(YamlReader r) {
  TrajectoryFamily t;
  t.kind = r.String("kind");
  if (t.kind != "press" && t.kind != "slide" && t.kind != "twist" && t.kind != "lift" &&
      t.kind != "load_ramp") {
    r.FailAt(r.Required("kind"),
             r.Join("kind"),
             fmt::format("'{}' is not one of press, slide, twist, lift, load_ramp", t.kind));
  }
  t.weight = ReadWeight(r);
  t.depth_mm = ReadDistribution(r, "depth_mm", Bound{0.0, 5.0, true});
  t.speed_mm_s = ReadDistribution(r, "speed_mm_s", kSpeed);
  if (t.kind == "slide") {
    t.distance_mm = ReadDistribution(r, "distance_mm", Bound{0.0, 100.0, true});
    t.direction_deg = ReadDistribution(r, "direction_deg", Bound{-360, 360}, 0.0);
  }
  if (t.kind == "load_ramp") {
    t.load_rate_per_s = ReadDistribution(r, "rate_per_s", Bound{0.0, 1e4, true});
    t.final_load = ReadDistribution(r, "final_load", Bound{0.0, 10.0, true});
    t.direction_deg = ReadDistribution(r, "direction_deg", Bound{-360, 360}, 0.0);
  }
  if (t.kind == "twist") {
    t.angle_deg = ReadDistribution(r, "angle_deg", Bound{-180, 180});
    t.angular_speed_deg_s = ReadDistribution(r, "angular_speed_deg_s", Bound{0.0, 1e4, true});
  }
  return t;
}

FrictionSpec ReadFriction(YamlReader r) {
  FrictionSpec f;
  f.mu = ReadDistribution(r, "mu", kMu);
  if (r.Has("regions")) {
    YamlReader g = r.Child("regions");
    f.region_count = ReadDistribution(g, "count", Bound{0, 8, false, true});
    f.region_mu = ReadDistribution(g, "mu", kMu);
    f.region_radius_mm = ReadDistribution(g, "radius_mm", Bound{0.0, 50.0, true}, 2.0);
    f.region_offset_mm = ReadDistribution(g, "offset_mm", Bound{0.0, 50.0}, 2.0);
  }
  return f;
}

// The session nuisances a spec may draw (scene `conditions:`, docs/render.md) and their ranges.
const std::map<std::string, Bound>& ConditionBounds() {
  static const auto* bounds = new std::map<std::string, Bound>{
      {"session_s", {0, 1e6}},
      {"illumination_gain", {0, 10, true}},
      {"illumination_offset", {-1, 1}},
      {"illumination_gradient", {-1, 1}},
      {"contrast_fade", {0, 1}},
      {"exposure_drift", {-1, 1}},
      {"creep_mm", {0, 1}},
  };
  return *bounds;
}

void ReadSensorConditions(YamlReader r, double poisson_ratio, DatasetSpec* spec) {
  spec->youngs_modulus_factor =
      ReadDistribution(r,
                       "youngs_modulus_factor",
                       Bound{TwinDeviation::kMinYoungsModulusFactor, TwinDeviation::kMaxYoungsModulusFactor},
                       1.0);
  // The twin's nu = nu x factor must stay < 0.5 (an incompressible body has no FEM model here).
  spec->poisson_ratio_factor =
      ReadDistribution(r, "poisson_ratio_factor", Bound{0, 0.4999 / poisson_ratio, true}, 1.0);
  // E is scaled from one model; each nu is a body model of its own, built once and cached.
  if (spec->poisson_ratio_factor.kind == Distribution::Kind::kUniform) {
    r.FailAt(r.Required("poisson_ratio_factor"),
             r.Join("poisson_ratio_factor"),
             "each value is a body model: draw it with choice, not uniform");
  }
  for (const auto& [key, bound] : ConditionBounds()) {
    if (r.Has(key)) spec->conditions[key] = ReadDistribution(r, key, bound);
  }
}

void ReadTwin(YamlReader r, DatasetSpec* spec) {
  spec->mesh_refinement = r.Double("mesh_refinement", 1.0);
  if (!(spec->mesh_refinement >= 1.0 && spec->mesh_refinement <= 4.0)) {
    r.FailAt(r.Required("mesh_refinement"), r.Join("mesh_refinement"), "must be in [1, 4]");
  }
  for (const char* key : {"margin_mm", "quadrature_points_per_side", "cells_per_pitch"}) {
    if (!r.Has(key)) continue;
    const double v = r.Double(key);
    if (!(v > 0.0 && std::isfinite(v))) r.FailAt(r.Required(key), r.Join(key), "must be > 0");
    spec->twin_options[key] = v;
  }
}

template <typename Family>
const Family& DrawWeighted(const std::vector<Family>& families, EpisodeRandom& random) {
  double total = 0.0;
  for (const Family& f : families) total += f.weight;
  double u = random.Uniform() * total;
  for (const Family& f : families) {
    if (u < f.weight) return f;
    u -= f.weight;
  }
  return families.back();
}

// The object's lowest z in its own frame, what rests `clearance_mm` above the fingertip.
double DrawObject(const DatasetSpec& spec,
                  EpisodeRandom& random,
                  nlohmann::json* object,
                  nlohmann::json* params) {
  const ObjectFamily& f = DrawWeighted(spec.objects, random);
  (*object)["shape"] = f.shape;
  (*params)["shape"] = f.shape;
  std::map<std::string, double> size;
  for (const auto& [key, d] : f.sizes) size[key] = d.Draw(random);
  double bottom_z = 0.0;
  if (f.shape == "box") {
    (*object)["size_mm"] = {size["size_x_mm"], size["size_y_mm"], size["size_z_mm"]};
    bottom_z = -0.5 * size["size_z_mm"];
  } else {
    for (const auto& [key, v] : size) {
      if (key == "rows" || key == "cols") {
        (*object)[key] = static_cast<int>(v);
      } else {
        (*object)[key] = v;
      }
    }
    if (f.shape == "sphere" || f.shape == "cylinder") bottom_z = -size["radius_mm"];
  }
  for (const auto& [key, v] : size) (*params)[key] = v;
  if (f.shape == "mesh") {
    const std::string& ply = f.ply_files[random.Index(f.ply_files.size())];
    const TriangleMesh mesh = ReadPly(ply);
    bottom_z = mesh.vertices.front().z();
    for (const Eigen::Vector3d& v : mesh.vertices) bottom_z = std::min(bottom_z, v.z());
    (*object)["ply"] = ply;
    (*params)["ply"] = fs::path(ply).filename().string();
  }
  const double yaw_deg = f.yaw_deg.Draw(random);
  const double z = spec.fingertip_top_mm + spec.clearance_mm - bottom_z;
  (*object)["position_mm"] = {0.0, 0.0, z};
  (*object)["rpy_deg"] = {0.0, 0.0, yaw_deg};
  (*params)["yaw_deg"] = yaw_deg;
  (*params)["position_mm"] = {0.0, 0.0, z};
  return bottom_z;
}

nlohmann::json DrawFriction(const FrictionSpec& spec,
                            double bottom_z,
                            EpisodeRandom& random,
                            nlohmann::json* params) {
  nlohmann::json friction = {{"default", spec.mu.Draw(random)}};
  (*params)["mu"] = friction["default"];
  const int count = static_cast<int>(spec.region_count.Draw(random));
  nlohmann::json regions = nlohmann::json::array();
  for (int i = 0; i < count; ++i) {
    const double mu = spec.region_mu.Draw(random);
    const double radius = spec.region_radius_mm.Draw(random);
    const double offset = spec.region_offset_mm.Draw(random);
    const double x = (2.0 * random.Uniform() - 1.0) * offset;
    const double y = (2.0 * random.Uniform() - 1.0) * offset;
    regions.push_back(
        {{"ball_center_mm", {x, y, bottom_z}}, {"ball_radius_mm", radius}, {"mu", mu}});
  }
  if (!regions.empty()) friction["regions"] = regions;
  (*params)["regions"] = regions;
  return friction;
}

nlohmann::json Keyframe(double t_s, double x, double y, double z, double yaw_deg = 0.0) {
  return {{"t_s", t_s}, {"position_mm", {x, y, z}}, {"rpy_deg", {0.0, 0.0, yaw_deg}}};
}

nlohmann::json DrawTrajectory(const DatasetSpec& spec,
                              EpisodeRandom& random,
                              nlohmann::json* params) {
  const TrajectoryFamily& f = DrawWeighted(spec.trajectories, random);
  const double depth = f.depth_mm.Draw(random);
  const double speed = f.speed_mm_s.Draw(random);
  const double in_z = spec.clearance_mm + depth;
  const double t_in = in_z / speed;
  *params = {{"kind", f.kind}, {"depth_mm", depth}, {"speed_mm_s", speed}};
  nlohmann::json keyframes = {Keyframe(0.0, 0, 0, 0), Keyframe(t_in, 0, 0, in_z)};
  nlohmann::json trajectory = {{"steps", spec.steps}};
  if (f.kind == "slide") {
    const double distance = f.distance_mm.Draw(random);
    const double direction = f.direction_deg.Draw(random) * M_PI / 180.0;
    keyframes.push_back(Keyframe(t_in + distance / speed,
                                 distance * std::cos(direction),
                                 distance * std::sin(direction),
                                 in_z));
    (*params)["distance_mm"] = distance;
    (*params)["direction_deg"] = direction * 180.0 / M_PI;
  } else if (f.kind == "twist") {
    const double angle = f.angle_deg.Draw(random);
    const double angular_speed = f.angular_speed_deg_s.Draw(random);
    keyframes.push_back(
        Keyframe(t_in + std::max(std::abs(angle), 1e-3) / angular_speed, 0, 0, in_z, angle));
    (*params)["angle_deg"] = angle;
    (*params)["angular_speed_deg_s"] = angular_speed;
  } else if (f.kind == "lift") {
    keyframes.push_back(Keyframe(2.0 * t_in, 0, 0, 0));
  } else if (f.kind == "load_ramp") {
    const double rate = f.load_rate_per_s.Draw(random);
    const double final_load = f.final_load.Draw(random);
    const double direction = f.direction_deg.Draw(random);
    // Held pressed while the load ramps from 0 (at t_in) to final_load.
    keyframes.push_back(Keyframe(t_in + final_load / rate, 0, 0, in_z));
    trajectory["tangential_load"] = {{"start_s", t_in},
                                     {"rate_per_s", rate},
                                     {"final_load", final_load},
                                     {"direction_deg", direction}};
    (*params)["rate_per_s"] = rate;
    (*params)["final_load"] = final_load;
    (*params)["direction_deg"] = direction;
  }
  trajectory["keyframes"] = keyframes;
  return trajectory;
}

}  // namespace

std::uint64_t EpisodeRandom::Next() { return SplitMix64(state_); }

double EpisodeRandom::Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

std::size_t EpisodeRandom::Index(std::size_t n) {
  TAC3D_DEMAND(n > 0);
  return std::min(n - 1, static_cast<std::size_t>(Uniform() * static_cast<double>(n)));
}

std::uint64_t EpisodeSeed(std::uint64_t spec_seed, int episode) {
  std::uint64_t state = spec_seed;
  const std::uint64_t mixed_seed = SplitMix64(state);
  state = mixed_seed ^ static_cast<std::uint64_t>(episode);
  return SplitMix64(state);
}

double Distribution::Draw(EpisodeRandom& random) const {
  switch (kind) {
    case Kind::kConstant:
      return values[0];
    case Kind::kUniform:
      return values[0] + (values[1] - values[0]) * random.Uniform();
    case Kind::kChoice:
      return values[random.Index(values.size())];
  }
  TAC3D_DEMAND(false);
}


DatasetSpec ParseDatasetSpec(const std::string& yaml_text,
                             const std::string& source,
                             const std::string& base_dir) {
  const YAML::Node root = ParseYamlDocument(yaml_text, source);
  DatasetSpec spec;
  YamlReader r(root, "", &source);
  spec.name = r.String("name");
  const int seed = r.Int("seed");
  if (seed < 0) r.FailAt(r.Required("seed"), "seed", "must be >= 0");
  spec.seed = static_cast<std::uint64_t>(seed);
  const std::string sensor = r.String("sensor", "default");
  spec.sensor = sensor == "default" || fs::path(sensor).is_absolute()
                    ? sensor
                    : fs::absolute(fs::path(base_dir) / sensor).string();
  const SensorConfig sensor_config =
      LoadSensorOrDefault(spec.sensor == "default" ? "" : spec.sensor);
  spec.fingertip_top_mm = sensor_config.elastic_body.thickness_mm;
  spec.steps = r.Int("steps");
  // An episode is simulated and stored whole: 10,000 steps are 3 GB of 640 x 480 images in
  // memory and 96 MB of a marker array in one chunk; 1,000,000 could be neither held nor stored.
  if (spec.steps < 2 || spec.steps > kMaxEpisodeSteps) {
    r.FailAt(r.Required("steps"), "steps", fmt::format("must be in [2, {}]", kMaxEpisodeSteps));
  }
  spec.images = r.Bool("images", true);
  spec.measured = r.Bool("measured", false);
  spec.clearance_mm = r.Double("clearance_mm", spec.clearance_mm);
  if (!(spec.clearance_mm > 0.0 && spec.clearance_mm <= 5.0)) {
    r.FailAt(r.Required("clearance_mm"), "clearance_mm", "must be in (0, 5]");
  }
  if (r.Has("twin")) ReadTwin(r.Child("twin"), &spec);
  if (r.Has("sensor_conditions")) {
    ReadSensorConditions(
        r.Child("sensor_conditions"), sensor_config.elastic_body.poisson_ratio, &spec);
  }
  const YAML::Node objects = r.Sequence("objects");
  if (objects.size() == 0) r.FailAt(objects, "objects", "must list at least one object family");
  for (size_t i = 0; i < objects.size(); ++i) {
    spec.objects.push_back(ReadObjectFamily(r.Element(objects, "objects", i), base_dir));
  }
  spec.friction = ReadFriction(r.Child("friction"));
  const YAML::Node trajectories = r.Sequence("trajectories");
  if (trajectories.size() == 0)
    r.FailAt(trajectories, "trajectories", "must list at least one trajectory family");
  for (size_t i = 0; i < trajectories.size(); ++i) {
    spec.trajectories.push_back(ReadTrajectoryFamily(r.Element(trajectories, "trajectories", i)));
  }
  return spec;
}

DatasetSpec LoadDatasetSpec(const std::string& path) {
  return ParseDatasetSpec(ReadFileCapped(path, kMaxConfigFileBytes, "dataset spec"),
                          path,
                          fs::absolute(path).parent_path().string());
}

EpisodeDraw DrawEpisode(const DatasetSpec& spec, int episode) {
  if (episode < 0)
    throw Error(fmt::format("dataset spec '{}': episode {} must be >= 0", spec.name, episode));
  EpisodeDraw draw;
  draw.episode = episode;
  draw.seed = EpisodeSeed(spec.seed, episode);
  EpisodeRandom random(draw.seed);
  // The order of the draws is part of the format: a change makes a spec give other episodes.
  nlohmann::json sensor_params = {
      {"youngs_modulus_factor", spec.youngs_modulus_factor.Draw(random)},
      {"poisson_ratio_factor", spec.poisson_ratio_factor.Draw(random)}};
  nlohmann::json conditions = nlohmann::json::object();
  for (const auto& [key, d] : spec.conditions) conditions[key] = d.Draw(random);
  sensor_params["conditions"] = conditions;
  nlohmann::json object = {{"name", "object"}};
  nlohmann::json object_params, friction_params, trajectory_params;
  const double bottom_z = DrawObject(spec, random, &object, &object_params);
  object["friction"] = DrawFriction(spec.friction, bottom_z, random, &friction_params);
  const nlohmann::json trajectory = DrawTrajectory(spec, random, &trajectory_params);
  nlohmann::json scene = {
      {"name", fmt::format("{}_{:06d}", spec.name, episode)},
      {"sensor", spec.sensor},
      {"deviation",
       {{"mesh_refinement", spec.mesh_refinement},
        {"youngs_modulus_factor", sensor_params["youngs_modulus_factor"]},
        {"poisson_ratio_factor", sensor_params["poisson_ratio_factor"]}}},
      {"objects", {object}},
      {"trajectory", trajectory},
  };
  if (!conditions.empty()) scene["conditions"] = conditions;
  draw.parameters = {{"sensor", sensor_params},
                     {"object", object_params},
                     {"friction", friction_params},
                     {"trajectory", trajectory_params}};
  draw.scene_yaml = scene.dump();
  return draw;
}

}  // namespace tac3d
