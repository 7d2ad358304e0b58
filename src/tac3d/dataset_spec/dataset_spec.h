#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace tac3d {

/// Episode i's random numbers: a SplitMix64 stream seeded by EpisodeSeed(spec seed, i), so an
/// episode's draws depend on nothing else (not on the worker, nor on the episodes before it).
class EpisodeRandom {
 public:
  explicit EpisodeRandom(std::uint64_t seed) : state_(seed) {}
  std::uint64_t Next();
  /// Uniform in [0, 1), 53 random bits.
  double Uniform();
  /// Uniform in {0, ..., n - 1}. @pre n > 0.
  std::size_t Index(std::size_t n);

 private:
  std::uint64_t state_;
};

/// The seed of episode `episode` of a spec seeded `spec_seed`: a hash of the pair only.
std::uint64_t EpisodeSeed(std::uint64_t spec_seed, int episode);

/// A number drawn once an episode: a constant, uniform in [low, high], or one of some values
/// (each equally likely). In YAML: `0.3`, `{uniform: [0.2, 1.0]}` or `{choice: [0.45, 0.49]}`.
struct Distribution {
  enum class Kind { kConstant, kUniform, kChoice };
  Kind kind = Kind::kConstant;
  /// constant: {value}; uniform: {low, high}; choice: the values.
  std::vector<double> values = {0.0};

  static Distribution Constant(double value) { return {Kind::kConstant, {value}}; }
  double Draw(EpisodeRandom& random) const;
};

/// One family of objects a spec draws from: a scene shape (docs/scenes.md) with its sizes as
/// distributions. A `mesh` family draws one PLY file of a folder.
struct ObjectFamily {
  std::string shape;  ///< sphere | cylinder | flat_punch | pins | box | mesh
  double weight = 1.0;
  /// The shape's size keys (radius_mm, length_mm, pitch_mm, rows, cols; box: size_x_mm,
  /// size_y_mm, size_z_mm), each drawn.
  std::map<std::string, Distribution> sizes;
  std::vector<std::string> ply_files;  ///< mesh: the folder's *.ply, sorted, absolute
  Distribution yaw_deg;                ///< the object's turn about z
};

/// One kind of sensor motion, each starting `clearance_mm` below the object and pressing in
/// `depth_mm`: press (in, and no more), slide (in, then `distance_mm` along `direction_deg` in
/// x-y: the tangential load ramps through incipient into gross slip), twist (in, then
/// `angle_deg` about z), lift (in, then back out to the start), load_ramp (in, then held while
/// a tangential force along `direction_deg` rises at `rate_per_s` times mu P a second to
/// `final_load` times mu P: stick, partial slip, and above 1 gross slip; Scene's
/// TangentialLoadRamp).
struct TrajectoryFamily {
  std::string kind;  ///< press | slide | twist | lift | load_ramp
  double weight = 1.0;
  Distribution depth_mm;
  Distribution speed_mm_s;  ///< sets the times (the simulation is quasi-static)
  Distribution distance_mm;
  Distribution direction_deg;  ///< slide, load_ramp
  Distribution angle_deg;
  Distribution angular_speed_deg_s;  ///< twist
  Distribution load_rate_per_s;      ///< load_ramp: mu P a second
  Distribution final_load;           ///< load_ramp: mu P
};

/// Where an object's friction comes from: its mu everywhere, and up to `region_count` balls of
/// another mu round points near where the fingertip meets it.
struct FrictionSpec {
  Distribution mu;
  Distribution region_count = Distribution::Constant(0);
  Distribution region_mu;
  Distribution region_radius_mm = Distribution::Constant(2.0);
  Distribution region_offset_mm = Distribution::Constant(2.0);  ///< centres in +-offset (x, y)
};

/// A dataset spec (docs/datasets.md, "Randomized datasets"): distributions of objects,
/// friction, trajectories and sensor conditions, the steps an episode and one seed.
struct DatasetSpec {
  std::string name;
  std::uint64_t seed = 0;
  std::string sensor = "default";  ///< "default" or an absolute sensor YAML path
  double fingertip_top_mm = 8.0;   ///< the sensor's thickness: where objects are placed above
  int steps = 100;                 ///< steps an episode
  bool images = true;
  /// Also run each episode's rendered images through the sensor's pipeline and store what it
  /// measures beside the truth (docs/datasets.md, "What the sensor measures"); rendered for it
  /// even when `images` is false.
  bool measured = false;
  double clearance_mm = 0.05;  ///< the object's gap to the fingertip at the start
  /// The twin: its scene deviation's mesh_refinement, and TwinBodyOptions by name
  /// (margin_mm, quadrature_points_per_side, cells_per_pitch) as `tac3d.simulate` takes them.
  double mesh_refinement = 1.0;
  std::map<std::string, double> twin_options;
  Distribution youngs_modulus_factor = Distribution::Constant(1.0);
  Distribution poisson_ratio_factor = Distribution::Constant(1.0);
  /// The session's nuisances by their scene key (illumination_gain, exposure_drift, creep_mm,
  /// ...; docs/render.md, "Session conditions"), each drawn.
  std::map<std::string, Distribution> conditions;
  std::vector<ObjectFamily> objects;
  FrictionSpec friction;
  std::vector<TrajectoryFamily> trajectories;
};

/// Parses a spec with the YAML reader every tac3d file uses (sensor/yaml_reader.h).
/// @param source the file name for messages; @param base_dir what relative paths are against.
/// @throws Error naming the source, the line and the key of a syntax error, a duplicated or
///   unknown key, a bad distribution or a value out of range.
DatasetSpec ParseDatasetSpec(const std::string& yaml_text,
                             const std::string& source,
                             const std::string& base_dir);
/// @throws Error as ParseDatasetSpec, or if the file cannot be read.
DatasetSpec LoadDatasetSpec(const std::string& path);

/// Episode i of a spec: its seed, what was drawn, and the scene to simulate.
struct EpisodeDraw {
  int episode = 0;
  std::uint64_t seed = 0;
  nlohmann::json parameters;  ///< {sensor, object, friction, trajectory}: the drawn values
  /// The scene (docs/scenes.md) as JSON, which ParseScene reads as YAML; paths absolute.
  std::string scene_yaml;
};

/// Draws episode `episode` from EpisodeRandom(EpisodeSeed(spec.seed, episode)), in a fixed
/// order. @throws Error if episode < 0, or a drawn mesh cannot be read.
EpisodeDraw DrawEpisode(const DatasetSpec& spec, int episode);

}  // namespace tac3d
