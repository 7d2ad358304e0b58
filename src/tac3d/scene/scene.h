#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "tac3d/geometry/geometry.h"
#include "tac3d/scene/ply.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/twin/calibration_set.h"
#include "tac3d/twin/session_conditions.h"

namespace tac3d {

/// A mesh object's triangles with a uniform grid over its vertices and triangles, for the
/// nearest vertex of a surface point (per-vertex friction) and the nearest point of the
/// surface (the friction evaluation's truth) in about constant time.
class IndexedMesh {
 public:
  /// @throws Error if the mesh has no vertices or a triangle indexes a vertex it lacks.
  explicit IndexedMesh(TriangleMesh mesh);
  const TriangleMesh& mesh() const { return mesh_; }
  /// Index of the vertex nearest to p (object frame).
  int NearestVertex(const Eigen::Vector3d& p) const;
  /// Whether a triangle has an area (degenerate ones, area under 1e-12 of their longest edge
  /// squared, are no surface).
  bool has_surface() const { return !surface_triangles_.empty(); }
  /// The point of the surface (the triangles with an area) nearest to p (object frame).
  /// @throws Error unless has_surface().
  Eigen::Vector3d ClosestSurfacePoint(const Eigen::Vector3d& p) const;

 private:
  Eigen::Vector3i CellOf(const Eigen::Vector3d& p) const;
  size_t CellIndex(int x, int y, int z) const {
    return (static_cast<size_t>(z) * cells_.y() + y) * cells_.x() + x;
  }

  TriangleMesh mesh_;
  Eigen::Vector3d origin_;
  double cell_mm_ = 1.0;
  Eigen::Vector3i cells_;
  std::vector<std::vector<int>> buckets_;  ///< vertices by cell
  std::vector<int> surface_triangles_;     ///< the triangles with an area
  /// Triangles by cell (each in every cell its bounding box overlaps): those of cell i are
  /// triangle_cells_[triangle_cell_start_[i] .. triangle_cell_start_[i + 1]).
  std::vector<int> triangle_cell_start_;
  std::vector<int> triangle_cells_;
};

/// Where the friction coefficient of an object's surface differs from its default: a box or
/// a ball in the object's frame. The first region that contains a point wins.
struct FrictionRegion {
  enum class Kind { kBox, kBall };
  Kind kind = Kind::kBox;
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero();     ///< box
  Eigen::Vector3d max_mm = Eigen::Vector3d::Zero();     ///< box
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();  ///< ball
  double radius_mm = 0.0;                               ///< ball
  double mu = 0.5;

  bool Contains(const Eigen::Vector3d& p_object) const;
};

/// The friction coefficient over an object's surface: a default, regions, or per vertex of
/// a mesh (a PLY vertex property).
struct FrictionMap {
  double default_mu = 0.5;
  std::vector<FrictionRegion> regions;
  /// For mesh objects: the PLY vertex property that holds mu (empty: not per vertex).
  std::string vertex_property;
};

/// A rigid object of a scene. Shapes, in the object's own frame:
/// - sphere: centre at the origin;
/// - cylinder: axis along y through the origin, length `length_mm` centred on it;
/// - flat_punch: a cylinder along z, its flat end the disc of `radius_mm` at z = 0, body z > 0,
///   its edge rounded with `edge_radius_mm` (0: sharp);
/// - pins: flat punches of `radius_mm` on a `rows` x `cols` grid of `pitch_mm` in z = 0;
/// - box: `size_mm` centred on the origin;
/// - mesh: a PLY triangle mesh, in mm.
struct SceneObject {
  enum class Shape { kSphere, kCylinder, kFlatPunch, kPins, kBox, kMesh };
  std::string name;
  Shape shape = Shape::kSphere;
  double radius_mm = 5.0;
  double edge_radius_mm = 0.0;  ///< flat_punch: in [0, radius_mm]
  double length_mm = 40.0;
  int rows = 1;
  int cols = 2;
  double pitch_mm = 2.54;
  Eigen::Vector3d size_mm = Eigen::Vector3d(40, 40, 10);
  std::string ply_path;                 ///< mesh: as written in the scene (relative to it)
  std::shared_ptr<const IndexedMesh> mesh;  ///< mesh: loaded with the scene
  Rigid3 world_from_object = Rigid3::Identity();
  FrictionMap friction;

  /// mu at a point of the surface (object frame): a vertex property is read at the mesh's
  /// nearest vertex, else the first region containing the point, else the default.
  double FrictionAt(const Eigen::Vector3d& p_object) const;
};

std::string_view ToString(SceneObject::Shape shape);

/// A tangential load ramp (docs/scenes.md, "A tangential load ramp"): from `start_s` on, the
/// contact is loaded by a tangential force rather than moved: |Q| = LoadAt(t) times the
/// contact's friction capacity mu P (sum of mu p A over the nodes, the previous step's),
/// along `direction_deg` in the sensor's x-y; the object follows the solved shift. Above 1
/// the contact slides as a whole (gross slip), Q = mu P.
struct TangentialLoadRamp {
  double start_s = 0.0;
  double rate_per_s = 1.0;      ///< the load's rise, capacities a second, > 0
  double final_load = 1.2;      ///< the load it stops at, capacities, in (0, 10]
  double direction_deg = 0.0;   ///< of the load on the fingertip, from the sensor's +x
  /// The load at time t, capacities (0 before start_s).
  double LoadAt(double t_s) const;
  /// The load's direction, a unit vector in the sensor's x-y.
  Eigen::Vector2d Direction() const;
};

/// world_from_sensor over time: keyframes interpolated linearly in position and by slerp in
/// rotation, sampled at `steps` equal intervals from the first keyframe's time to the last's.
struct Trajectory {
  struct Keyframe {
    double t_s = 0.0;
    Rigid3 world_from_sensor = Rigid3::Identity();
  };
  std::vector<Keyframe> keyframes;
  int steps = 100;
  /// A tangential load from its start_s on; the keyframes must not move the sensor in x-y nor
  /// turn it from then on (the load, not the pose, drives the tangential motion).
  std::optional<TangentialLoadRamp> tangential_load;

  /// The pose at time t (clamped to the keyframes' span).
  Rigid3 PoseAt(double t_s) const;
  /// The time of step k (0 .. steps - 1).
  double StepTime(int k) const;
  double duration_s() const { return keyframes.back().t_s - keyframes.front().t_s; }
};

/// How the twin's fingertip differs from the sensor the pipeline is given (DESIGN.md: a
/// finer mesh, elastic constants off nominal), so measurements are judged against a truth
/// the pipeline's model does not share.
struct TwinDeviation {
  /// The twin's FEM refinement (pipeline's edges / this). 1.5 by default: the finest the
  /// default dome is still factored directly (559,482 free DOFs, ~7 GB), which the
  /// simulation's ~1,200 solves need (TwinBody refuses a larger model).
  double mesh_refinement = 1.5;
  /// The twin's E over the sensor's, in [kMinYoungsModulusFactor, kMaxYoungsModulusFactor]: a
  /// silicone a tenth as stiff is already no fingertip, and far below it the contact solver's
  /// force tolerance swallows the forces (zero at 1e-100, no end at 1e-200).
  double youngs_modulus_factor = 1.1;
  static constexpr double kMinYoungsModulusFactor = 0.1;
  static constexpr double kMaxYoungsModulusFactor = 2.0;
  double poisson_ratio_factor = 0.99;
};

/// A twin experiment: the fingertip, the objects around it and the sensor's motion.
/// World frame: at the identity pose the sensor frame is the world frame, the fingertip's
/// outer surface faces +z with its top at z = thickness, and objects are placed above it.
struct Scene {
  std::string name;
  SensorConfig sensor;
  TwinDeviation deviation;
  /// The twin's nuisances over the session, from the trajectory's first keyframe on
  /// (docs/render.md, "Session conditions"); none by default.
  SessionConditions conditions;
  /// This twin sensor's manufacturing spread: its camera renders through
  /// PerturbSensor(sensor, *spread), which only a calibration recovers; none by default.
  std::optional<SensorPerturbationOptions> spread;
  std::vector<SceneObject> objects;
  Trajectory trajectory;

  /// @throws Error naming the field and its bound.
  void Validate() const;
};

/// Reads a scene YAML file (format: docs/scenes.md). Paths inside it (a sensor YAML, PLY
/// meshes, a trajectory CSV) are relative to the scene file's folder.
/// @throws Error naming the file, the key path and what is wrong.
Scene LoadScene(const std::string& path);
/// @param base_dir where relative paths in the text are resolved.
Scene ParseScene(const std::string& yaml_text, const std::string& source, const std::string& base_dir);

/// Poses from a CSV file: a header `t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg`, then one
/// keyframe a line (roll about x, pitch about y, yaw about z, applied in that order).
/// @throws Error naming the file and line of anything malformed, or times not increasing;
///   naming the file when it does not exist, is a folder or not a regular file, or is larger
///   than kMaxConfigFileBytes (util/file_io.h).
std::vector<Trajectory::Keyframe> ReadTrajectoryCsv(const std::string& path);

/// world_from_sensor from a position and roll, pitch, yaw (deg): R = Rz(yaw) Ry(pitch) Rx(roll).
Rigid3 PoseFromRpy(const Eigen::Vector3d& position_mm, const Eigen::Vector3d& rpy_deg);

/// The built-in scenes: "force_calibration", "probe", "pins", "two_material_slide", "bottle",
/// and the friction-map scenes "friction_block", "friction_bottle", "friction_paint_can",
/// "friction_tool_handle".
std::vector<std::string> BuiltInSceneNames();
/// Also the incipient-slip family's names (IncipientSceneSpec).
/// @throws Error listing the names if `name` is not one.
Scene BuiltInScene(const std::string& name);

/// One scene of the incipient-slip family (docs/slip.md, "Friction before it
/// slips"): an indenter on the fingertip's top, pressed to a depth, held, then slid along +x at
/// constant speed far enough that the tangential load ramps through partial slip into gross
/// slip (the twin is displacement-driven), and held sliding. Built-in name:
/// `incipient_<indenter>_mu<mu>_<load>_<ramp>`, with `_<rate>hz` when the frame rate is not
/// the default, e.g. `incipient_punch_mu0.3_heavy_fast_15hz`.
struct IncipientSceneSpec {
  /// sphere of radius 10 mm; cylinder of radius 10 mm, axis along y (slid across it); punch: a
  /// flat punch of radius 2.5 mm with a 0.75 mm edge radius.
  enum class Indenter { kSphere, kCylinder, kPunch };
  enum class Load { kLight, kHeavy };  ///< pressed 0.25 mm or 0.5 mm
  enum class Ramp { kSlow, kFast };    ///< the slide lasts 2 s or 0.5 s
  Indenter indenter = Indenter::kSphere;
  double mu = 0.6;  ///< the indenter's friction coefficient, in (0, 2]
  Load load = Load::kLight;
  Ramp ramp = Ramp::kSlow;
  /// Camera frames (twin steps) a second, in [5, 1000]: the times are fixed, so a lower rate
  /// is a shorter simulation of the same motion.
  double frame_rate_hz = 60.0;

  std::string Name() const;
  double depth_mm() const;
  double ramp_s() const;
  /// The phases in whole frames (at least one each): press 0.25 s, hold 0.1 s, ramp ramp_s().
  int press_frames() const;
  int hold_frames() const;
  int ramp_frames() const;
  /// When the slide starts, on the scene's clock (after the 25 lead-in frames, the press and
  /// the hold).
  double ramp_start_s() const;
  /// The slide: 3 mu depth + 0.1 mm, past the tangential displacement at which a Hertzian
  /// contact slips as a whole (about 1.5 mu depth for an incompressible half-space).
  double slide_mm() const;
  /// @throws Error naming the field and its bound.
  void Validate() const;
};

std::string_view ToString(IncipientSceneSpec::Indenter indenter);
std::string_view ToString(IncipientSceneSpec::Load load);
std::string_view ToString(IncipientSceneSpec::Ramp ramp);

/// The family: sphere, cylinder and punch x mu 0.3, 0.6, 1.0 x light, heavy x slow, fast (36
/// scenes) at `frame_rate_hz`.
std::vector<IncipientSceneSpec> IncipientSceneFamily(double frame_rate_hz = 60.0);

/// The spec of an `incipient_...` name, or nullopt if `name` is not of that form.
std::optional<IncipientSceneSpec> ParseIncipientSceneName(const std::string& name);

/// The scene: 25 lead-in frames clear of the indenter (as every built-in scene), the press
/// over 0.25 s, a 0.1 s hold, then the slide over ramp_s(); a frame every 1 / frame_rate_hz s.
/// @throws Error if the spec is invalid.
Scene IncipientScene(const IncipientSceneSpec& spec);
/// The same on another fingertip (the tests' small sensor), placed on its top.
Scene IncipientScene(const IncipientSceneSpec& spec, const SensorConfig& sensor);

/// A scene file or a built-in name.
Scene LoadSceneOrBuiltIn(const std::string& path_or_name);

}  // namespace tac3d
