// The paper's experiments (Fig. 5, 7, 8, 9) as scenes. Distances follow the world
// convention of Scene: the fingertip faces +z at the identity pose, objects sit above it
// with a small clearance, and the sensor moves up into them.
#include <algorithm>
#include <cmath>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "tac3d/scene/scene.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr double kClearanceMm = 0.5;  // gap between the fingertip and an object at rest
// Steps every built-in scene holds its first pose (clear of the objects) before it moves, so
// the pipeline's reference (PipelineOptions::reference_frames, 20) sees an unloaded sensor.
constexpr int kLeadInSteps = 25;

Scene Base(const std::string& name) {
  Scene scene;
  scene.name = name;
  scene.sensor = DefaultSensorConfig();
  return scene;
}

// Height of the fingertip's outer surface at (x, y) in the sensor frame.
double SurfaceZ(const SensorConfig& sensor, double x, double y) {
  const double r = sensor.elastic_body.outer_radius_mm;
  return sensor.SphereCenter().z() + std::sqrt(r * r - x * x - y * y);
}

SceneObject Object(const std::string& name, SceneObject::Shape shape, const Eigen::Vector3d& position_mm,
                   double mu) {
  SceneObject o;
  o.name = name;
  o.shape = shape;
  o.world_from_object = PoseFromRpy(position_mm, Eigen::Vector3d::Zero());
  o.friction.default_mu = mu;
  return o;
}

// A box of the object's frame where mu differs from the object's default.
FrictionRegion BoxRegion(const Eigen::Vector3d& min_mm, const Eigen::Vector3d& max_mm, double mu) {
  FrictionRegion r;
  r.kind = FrictionRegion::Kind::kBox;
  r.min_mm = min_mm;
  r.max_mm = max_mm;
  r.mu = mu;
  return r;
}

// The box of the cylinder's (axis along y) bottom half whose points lie between phi_from and
// phi_to (deg, phi = 0 at the bottom line, x = -r sin(phi)) and between y_from and y_to.
FrictionRegion CylinderPatch(double radius, double phi_from_deg, double phi_to_deg, double y_from,
                             double y_to, double mu) {
  const auto x = [radius](double phi_deg) { return -radius * std::sin(phi_deg * M_PI / 180.0); };
  return BoxRegion({x(phi_to_deg), y_from, -radius - 1}, {x(phi_from_deg), y_to, 0}, mu);
}

void Add(Trajectory& t, double time_s, const Eigen::Vector3d& position_mm,
         const Eigen::Vector3d& rpy_deg = Eigen::Vector3d::Zero()) {
  t.keyframes.push_back({time_s, PoseFromRpy(position_mm, rpy_deg)});
}

// A 10 mm sphere pressed 12 times: depths 0.3-1.2 mm, then slid 0-0.6 mm in 12 directions
// while pressed (the normal and tangential force span of a force calibration, Fig. 5).
Scene ForceCalibration() {
  Scene s = Base("force_calibration");
  const double top = s.sensor.elastic_body.thickness_mm;
  SceneObject sphere = Object("indenter", SceneObject::Shape::kSphere, {0, 0, top + kClearanceMm + 10.0}, 0.8);
  sphere.radius_mm = 10.0;
  s.objects.push_back(sphere);
  double t = 0.0;
  Add(s.trajectory, t, {0, 0, 0});
  for (int k = 0; k < 12; ++k) {
    const double depth = 0.3 + 0.3 * (k % 4);
    const double shift = 0.2 * (k % 3 + (k % 4 == 0 ? 0 : 1));
    const double angle = 2.0 * M_PI * k / 12.0;
    const Eigen::Vector3d pressed(0, 0, kClearanceMm + depth);
    Add(s.trajectory, t += 1.0, pressed);
    Add(s.trajectory, t += 1.0, pressed + Eigen::Vector3d(shift * std::cos(angle), shift * std::sin(angle), 0));
    Add(s.trajectory, t += 1.0, {0, 0, 0});
  }
  s.trajectory.steps = 12 * 3 * 10 + 1;
  return s;
}

// A 2 mm flat probe pressed 0.3 mm at five points of the fingertip (Fig. 7).
Scene Probe() {
  Scene s = Base("probe");
  const double top = s.sensor.elastic_body.thickness_mm;
  SceneObject probe = Object("probe", SceneObject::Shape::kFlatPunch, {0, 0, top + kClearanceMm}, 0.8);
  probe.radius_mm = 1.0;
  s.objects.push_back(probe);
  const double p = s.sensor.markers.pitch_mm;
  const Eigen::Vector2d points[] = {{0, 0}, {0.5 * p, 0}, {0.5 * p, 0.5 * p}, {4.5 * p, -2 * p}, {-6 * p, 5.5 * p}};
  double t = 0.0;
  for (const Eigen::Vector2d& q : points) {
    // The sensor moves so the probe is over fingertip point q, then presses 0.3 mm.
    const double lift = top - SurfaceZ(s.sensor, q.x(), q.y());
    Add(s.trajectory, t, {-q.x(), -q.y(), -lift});
    Add(s.trajectory, t += 1.0, {-q.x(), -q.y(), kClearanceMm - lift + 0.3});
    Add(s.trajectory, t += 1.0, {-q.x(), -q.y(), -lift});
    t += 0.5;
  }
  s.trajectory.steps = 5 * 2 * 10 + 1;
  return s;
}

// A 3 x 3 array of 1 mm pins at 2.54 mm pitch pressed 0.3 mm at the centre (Fig. 7).
Scene Pins() {
  Scene s = Base("pins");
  const double top = s.sensor.elastic_body.thickness_mm;
  SceneObject pins = Object("pins", SceneObject::Shape::kPins, {0, 0, top + kClearanceMm}, 0.8);
  pins.radius_mm = 0.5;
  pins.rows = 3;
  pins.cols = 3;
  pins.pitch_mm = 2.54;
  s.objects.push_back(pins);
  Add(s.trajectory, 0.0, {0, 0, 0});
  Add(s.trajectory, 1.0, {0, 0, kClearanceMm + 0.3});
  Add(s.trajectory, 2.0, {0, 0, 0});
  s.trajectory.steps = 41;
  return s;
}

// A block whose x < 0 half has mu = 1.0 and x >= 0 half mu = 0.4: pressed 0.3 mm at x = -8,
// slid 16 mm along +x across the boundary, lifted; 500 steps (Fig. 8).
Scene TwoMaterialSlide() {
  Scene s = Base("two_material_slide");
  const double top = s.sensor.elastic_body.thickness_mm;
  SceneObject block = Object("block", SceneObject::Shape::kBox, {0, 0, top + kClearanceMm + 5.0}, 0.4);
  block.size_mm = {60, 40, 10};
  block.friction.regions.push_back(BoxRegion({-31, -21, -6}, {0, 21, 6}, 1.0));
  s.objects.push_back(block);
  // 0.3 mm keeps the slide inside the sensor's rated range (Fz <= 10 N, |Fx| <= 5 N on the
  // mu = 1.0 half; it peaks at 4.0 N each): 0.8 mm into the 45 mm dome loads it with ~27 N.
  const double depth = 0.3;
  Add(s.trajectory, 0.0, {-8, 0, 0});
  Add(s.trajectory, 1.0, {-8, 0, kClearanceMm + depth});
  Add(s.trajectory, 9.0, {8, 0, kClearanceMm + depth});
  Add(s.trajectory, 10.0, {8, 0, 0});
  s.trajectory.steps = 500;
  return s;
}

// The bottle of Fig. 9: a cylinder (axis along y through axis_point, mu = 0.3, 120 mm long)
// with an 8 mm rubber disc (mu = 1.2) 20 deg round from its bottom line.
SceneObject BottleWithRubberDisc(const Eigen::Vector3d& axis_point, double radius) {
  SceneObject bottle = Object("bottle", SceneObject::Shape::kCylinder, axis_point, 0.3);
  bottle.radius_mm = radius;
  bottle.length_mm = 120.0;
  FrictionRegion disc;
  disc.kind = FrictionRegion::Kind::kBall;
  const double disc_angle = 20.0 * M_PI / 180.0;
  disc.center_mm = {-radius * std::sin(disc_angle), 0, -radius * std::cos(disc_angle)};  // touched at phi = 20 deg
  disc.radius_mm = 4.0;
  disc.mu = 1.2;
  bottle.friction.regions.push_back(disc);
  return bottle;
}

// A bottle-like cylinder (radius 30 mm, axis along y, mu = 0.3) with an 8 mm rubber disc
// (mu = 1.2) 20 deg round from its bottom line; the fingertip presses 0.3 mm and slides
// round the cylinder from -30 to +50 deg, across the disc (Fig. 1, 9).
Scene Bottle() {
  Scene s = Base("bottle");
  const double top = s.sensor.elastic_body.thickness_mm;
  const double radius = 30.0;
  const Eigen::Vector3d axis_point(0, 0, top + kClearanceMm + radius);
  s.objects.push_back(BottleWithRubberDisc(axis_point, radius));
  // The sensor's z axis points at the cylinder's axis: turned by phi about y round it.
  auto pose = [&](double phi_deg, double depth) -> std::pair<Eigen::Vector3d, Eigen::Vector3d> {
    const double phi = phi_deg * M_PI / 180.0;
    const double reach = radius + top - depth;  // sensor origin to axis
    return {axis_point + Eigen::Vector3d(-reach * std::sin(phi), 0, -reach * std::cos(phi)),
            Eigen::Vector3d(0, phi_deg, 0)};
  };
  // 0.3 mm keeps the slide inside the rated range (0.8 mm loaded 17 N normal and, on the
  // rubber, 14 N tangential).
  const double depth = 0.3;
  auto add = [&](double t, double phi_deg, double d) {
    const auto [p, rpy] = pose(phi_deg, d);
    Add(s.trajectory, t, p, rpy);
  };
  add(0.0, -30, -kClearanceMm);
  // A keyframe every degree: positions are interpolated along chords, which cut 0.0014 mm
  // into the arc between keyframes.
  for (int phi = -30; phi <= 50; ++phi) add(1.0 + 8.0 * (phi + 30) / 80.0, phi, depth);
  add(10.0, 50, -kClearanceMm);
  s.trajectory.steps = 400;
  return s;
}

// ---- Friction-map scenes (paper section IV.B, Fig. 1, 8, 9) ----
// The sensor slides over the object in overlapping strokes that together cover a patch of
// its surface: pressed 0.3 mm (inside the rated range, as above), slid at kStrokeStepMm a
// step, lifted back to the clearance, moved clear of the object to the next stroke's start.
// A stroke never drags across another: every stroke starts from a lift.
constexpr double kStrokeStepMm = 0.08;  // sliding per step (7x the slip threshold, 0.011 mm)
constexpr int kPressSteps = 10;          // 0.8 mm down (clearance + depth) or up
constexpr int kTransferSteps = 10;       // lifted, to the next stroke's start

// Keyframes at step counts: the trajectory's steps are one a unit of `step`, so each
// keyframe lands on a step and the speed between keyframes is set by their step counts.
class StepPath {
 public:
  explicit StepPath(Trajectory& t) : t_(t) {}
  void Start(const Rigid3& pose) { t_.keyframes.push_back({0.0, pose}); }
  void MoveTo(const Rigid3& pose, int steps) {
    step_ += steps;
    t_.keyframes.push_back({step_ * kStepS, pose});
  }
  void Finish() { t_.steps = step_ + 1; }

 private:
  static constexpr double kStepS = 0.01;
  Trajectory& t_;
  int step_ = 0;
};

// Two materials on a flat block (Fig. 1, 8): the block of two_material_slide, mu 1.0 for
// x < 0 and 0.4 for x >= 0, stroked along x from -12 to +12 mm at y = -6, 0, +6 (the
// pressed patch is ~10 mm across, so neighbouring strokes overlap by ~4 mm), alternating
// direction.
Scene FrictionBlock() {
  Scene s = Base("friction_block");
  const double top = s.sensor.elastic_body.thickness_mm;
  SceneObject block = Object("block", SceneObject::Shape::kBox, {0, 0, top + kClearanceMm + 5.0}, 0.4);
  block.size_mm = {60, 40, 10};
  block.friction.regions.push_back(BoxRegion({-31, -21, -6}, {0, 21, 6}, 1.0));
  s.objects.push_back(block);
  const double depth = 0.3, half_length = 12.0;
  const int slide_steps = static_cast<int>(std::lround(2.0 * half_length / kStrokeStepMm));
  StepPath path(s.trajectory);
  const double ys[] = {-6.0, 0.0, 6.0};
  for (int k = 0; k < 3; ++k) {
    const double from = k % 2 == 0 ? -half_length : half_length;
    const Eigen::Vector3d lifted(from, ys[k], 0.0);
    if (k == 0) path.Start(PoseFromRpy(lifted, Eigen::Vector3d::Zero()));
    else path.MoveTo(PoseFromRpy(lifted, Eigen::Vector3d::Zero()), kTransferSteps);
    path.MoveTo(PoseFromRpy({from, ys[k], kClearanceMm + depth}, Eigen::Vector3d::Zero()), kPressSteps);
    path.MoveTo(PoseFromRpy({-from, ys[k], kClearanceMm + depth}, Eigen::Vector3d::Zero()), slide_steps);
    path.MoveTo(PoseFromRpy({-from, ys[k], 0.0}, Eigen::Vector3d::Zero()), kPressSteps);
  }
  path.Finish();
  return s;
}

// Strokes round a cylinder (axis along y through axis_point, radius r) between phi_from and
// phi_to (deg; phi = 0 at its bottom line, the sensor's z axis pointing at the axis, as in
// Bottle) at the given y offsets, alternating direction; a keyframe every degree (the sensor
// origin's chord between two cuts (r + thickness)(1 - cos 0.5 deg) into its arc: the press
// is 0.0014 mm deeper halfway between keyframes at r = 30, 0.0018 mm at r = 40).
void CylinderStrokes(Trajectory& t, const Eigen::Vector3d& axis_point, double radius, double top,
                     double phi_from, double phi_to, const std::vector<double>& ys) {
  const double depth = 0.3;
  auto pose = [&](double phi_deg, double y, double d) {
    const double phi = phi_deg * M_PI / 180.0;
    const double reach = radius + top - d;  // sensor origin to axis
    return PoseFromRpy(axis_point + Eigen::Vector3d(-reach * std::sin(phi), y, -reach * std::cos(phi)),
                       Eigen::Vector3d(0, phi_deg, 0));
  };
  const int steps_per_degree =
      static_cast<int>(std::lround(radius * M_PI / 180.0 / kStrokeStepMm));
  const int degrees = static_cast<int>(std::lround(phi_to - phi_from));
  StepPath path(t);
  for (size_t k = 0; k < ys.size(); ++k) {
    const double from = k % 2 == 0 ? phi_from : phi_to, dir = k % 2 == 0 ? 1.0 : -1.0;
    if (k == 0) path.Start(pose(from, ys[k], -kClearanceMm));
    else path.MoveTo(pose(from, ys[k], -kClearanceMm), kTransferSteps);
    path.MoveTo(pose(from, ys[k], depth), kPressSteps);
    for (int i = 1; i <= degrees; ++i) path.MoveTo(pose(from + dir * i, ys[k], depth), steps_per_degree);
    path.MoveTo(pose(from + dir * degrees, ys[k], -kClearanceMm), kPressSteps);
  }
  path.Finish();
}

// The bottle of Bottle (radius 30 mm, mu 0.3, an 8 mm rubber disc of mu 1.2 at phi = 20 deg,
// Fig. 1, 9), stroked round from phi = 0 to 40 deg at y = -5, 0, +5 mm: the pressed patch is
// ~7 mm round the cylinder and ~10 mm along it, so the strokes overlap by ~5 mm and cover
// the disc.
Scene FrictionBottle() {
  Scene s = Base("friction_bottle");
  const double top = s.sensor.elastic_body.thickness_mm;
  const double radius = 30.0;
  const Eigen::Vector3d axis_point(0, 0, top + kClearanceMm + radius);
  s.objects.push_back(BottleWithRubberDisc(axis_point, radius));
  CylinderStrokes(s.trajectory, axis_point, radius, top, 0.0, 40.0, {-5.0, 0.0, 5.0});
  return s;
}

// A paint can (cylinder of radius 40 mm, axis along y) with three materials, one in each of
// the paper's bands: painted metal mu 0.65 (green), a strip of rubber tape round it at
// y in [-14, -4] mm, mu 1.0 (red), and a paper sticker at phi in [5, 30] deg, y in [-1, 14]
// mm, mu 0.35 (blue). Stroked round from phi = -15 to 25 deg at y = -6, 0, +6 mm.
Scene FrictionPaintCan() {
  Scene s = Base("friction_paint_can");
  const double top = s.sensor.elastic_body.thickness_mm;
  const double radius = 40.0;
  const Eigen::Vector3d axis_point(0, 0, top + kClearanceMm + radius);
  SceneObject can = Object("can", SceneObject::Shape::kCylinder, axis_point, 0.65);
  can.radius_mm = radius;
  can.length_mm = 100.0;
  const FrictionRegion tape =
      BoxRegion({-radius - 1, -14, -radius - 1}, {radius + 1, -4, radius + 1}, 1.0);
  can.friction.regions = {tape, CylinderPatch(radius, 5, 30, -1, 14, 0.35)};  // the sticker
  s.objects.push_back(can);
  CylinderStrokes(s.trajectory, axis_point, radius, top, -15.0, 25.0, {-6.0, 0.0, 6.0});
  return s;
}

// A tool handle, held out of the friction map's tuning (its settings were chosen on the three
// scenes above before this one was simulated): a cylinder of radius 16 mm, much more curved
// than the bottle and the can, of plastic (mu 0.45, blue) with a rubber grip for y < -3 mm
// (mu 1.1, red) and a printed label at phi in [0, 18] deg, y in [3, 15] mm (mu 0.7, green).
// Stroked round from -20 to +30 deg at y = -6, 0, +6 mm.
Scene FrictionToolHandle() {
  Scene s = Base("friction_tool_handle");
  const double top = s.sensor.elastic_body.thickness_mm;
  const double radius = 16.0;
  const Eigen::Vector3d axis_point(0, 0, top + kClearanceMm + radius);
  SceneObject handle = Object("handle", SceneObject::Shape::kCylinder, axis_point, 0.45);
  handle.radius_mm = radius;
  handle.length_mm = 100.0;
  const FrictionRegion grip =
      BoxRegion({-radius - 1, -51, -radius - 1}, {radius + 1, -3, radius + 1}, 1.1);
  handle.friction.regions = {grip, CylinderPatch(radius, 0, 18, 3, 15, 0.7)};  // the label
  s.objects.push_back(handle);
  CylinderStrokes(s.trajectory, axis_point, radius, top, -20.0, 30.0, {-6.0, 0.0, 6.0});
  return s;
}

// Holds the first pose for kLeadInSteps more steps at the trajectory's step spacing: the
// keyframes move later by that time and the step count grows by kLeadInSteps.
void AddLeadIn(Trajectory& t) {
  const double dt = t.duration_s() / (t.steps - 1);
  for (Trajectory::Keyframe& k : t.keyframes) k.t_s += kLeadInSteps * dt;
  t.keyframes.insert(t.keyframes.begin(), {t.keyframes.front().t_s - kLeadInSteps * dt,
                                           t.keyframes.front().world_from_sensor});
  t.steps += kLeadInSteps;
}

constexpr double kIncipientPressS = 0.25;
constexpr double kIncipientHoldS = 0.1;

std::string FormatNumber(double value) { return fmt::format("{:g}", value); }

}  // namespace

std::string_view ToString(IncipientSceneSpec::Indenter indenter) {
  switch (indenter) {
    case IncipientSceneSpec::Indenter::kSphere: return "sphere";
    case IncipientSceneSpec::Indenter::kCylinder: return "cylinder";
    case IncipientSceneSpec::Indenter::kPunch: return "punch";
  }
  return "?";
}

std::string_view ToString(IncipientSceneSpec::Load load) {
  return load == IncipientSceneSpec::Load::kLight ? "light" : "heavy";
}

std::string_view ToString(IncipientSceneSpec::Ramp ramp) {
  return ramp == IncipientSceneSpec::Ramp::kSlow ? "slow" : "fast";
}

std::string IncipientSceneSpec::Name() const {
  std::string name = fmt::format("incipient_{}_mu{}_{}_{}", ToString(indenter), FormatNumber(mu),
                                 ToString(load), ToString(ramp));
  if (frame_rate_hz != IncipientSceneSpec{}.frame_rate_hz) name += fmt::format("_{}hz", FormatNumber(frame_rate_hz));
  return name;
}

double IncipientSceneSpec::depth_mm() const { return load == Load::kLight ? 0.25 : 0.5; }

double IncipientSceneSpec::ramp_s() const { return ramp == Ramp::kSlow ? 2.0 : 0.5; }

int IncipientSceneSpec::press_frames() const {
  return std::max(1, static_cast<int>(std::lround(kIncipientPressS * frame_rate_hz)));
}

int IncipientSceneSpec::hold_frames() const {
  return std::max(1, static_cast<int>(std::lround(kIncipientHoldS * frame_rate_hz)));
}

int IncipientSceneSpec::ramp_frames() const {
  return std::max(1, static_cast<int>(std::lround(ramp_s() * frame_rate_hz)));
}

double IncipientSceneSpec::ramp_start_s() const {
  return (kLeadInSteps + press_frames() + hold_frames()) / frame_rate_hz;
}

double IncipientSceneSpec::slide_mm() const { return 3.0 * mu * depth_mm() + 0.1; }

void IncipientSceneSpec::Validate() const {
  if (!(mu > 0.0 && mu <= 2.0)) throw Error(fmt::format("incipient scene: mu must be in (0, 2], got {}", mu));
  if (!(frame_rate_hz >= 5.0 && frame_rate_hz <= 1000.0)) {
    throw Error(fmt::format("incipient scene: frame_rate_hz must be in [5, 1000], got {}", frame_rate_hz));
  }
}

std::vector<IncipientSceneSpec> IncipientSceneFamily(double frame_rate_hz) {
  using Spec = IncipientSceneSpec;
  std::vector<Spec> family;
  for (const Spec::Indenter indenter : {Spec::Indenter::kSphere, Spec::Indenter::kCylinder, Spec::Indenter::kPunch}) {
    for (const double mu : {0.3, 0.6, 1.0}) {
      for (const Spec::Load load : {Spec::Load::kLight, Spec::Load::kHeavy}) {
        for (const Spec::Ramp ramp : {Spec::Ramp::kSlow, Spec::Ramp::kFast}) {
          family.push_back({indenter, mu, load, ramp, frame_rate_hz});
        }
      }
    }
  }
  return family;
}

std::optional<IncipientSceneSpec> ParseIncipientSceneName(const std::string& name) {
  using Spec = IncipientSceneSpec;
  const std::string prefix = "incipient_";
  if (name.rfind(prefix, 0) != 0) return std::nullopt;
  std::vector<std::string> parts;
  for (size_t from = prefix.size(); from <= name.size();) {
    const size_t to = std::min(name.find('_', from), name.size());
    parts.push_back(name.substr(from, to - from));
    from = to + 1;
  }
  if (parts.size() != 4 && parts.size() != 5) return std::nullopt;
  Spec spec;
  const auto number = [](const std::string& text, double* value) {
    try {
      size_t used = 0;
      *value = std::stod(text, &used);
      return used == text.size() && !text.empty();
    } catch (const std::exception&) {
      return false;
    }
  };
  bool ok = parts[1].rfind("mu", 0) == 0 && number(parts[1].substr(2), &spec.mu);
  if (parts[0] == "sphere") spec.indenter = Spec::Indenter::kSphere;
  else if (parts[0] == "cylinder") spec.indenter = Spec::Indenter::kCylinder;
  else if (parts[0] == "punch") spec.indenter = Spec::Indenter::kPunch;
  else ok = false;
  if (parts[2] == "light" || parts[2] == "heavy") spec.load = parts[2] == "light" ? Spec::Load::kLight : Spec::Load::kHeavy;
  else ok = false;
  if (parts[3] == "slow" || parts[3] == "fast") spec.ramp = parts[3] == "slow" ? Spec::Ramp::kSlow : Spec::Ramp::kFast;
  else ok = false;
  if (parts.size() == 5) {
    const std::string& rate = parts[4];
    ok = ok && rate.size() > 2 && rate.substr(rate.size() - 2) == "hz" &&
         number(rate.substr(0, rate.size() - 2), &spec.frame_rate_hz);
  }
  if (!ok) return std::nullopt;
  return spec;
}

Scene IncipientScene(const IncipientSceneSpec& spec) { return IncipientScene(spec, DefaultSensorConfig()); }

Scene IncipientScene(const IncipientSceneSpec& spec, const SensorConfig& sensor) {
  using Spec = IncipientSceneSpec;
  spec.Validate();
  Scene s = Base(spec.Name());
  s.sensor = sensor;
  const double top = s.sensor.elastic_body.thickness_mm;
  SceneObject indenter;
  switch (spec.indenter) {
    case Spec::Indenter::kSphere:
      indenter = Object("sphere", SceneObject::Shape::kSphere, {0, 0, top + kClearanceMm + 10.0}, spec.mu);
      indenter.radius_mm = 10.0;
      break;
    case Spec::Indenter::kCylinder:
      indenter = Object("cylinder", SceneObject::Shape::kCylinder, {0, 0, top + kClearanceMm + 10.0}, spec.mu);
      indenter.radius_mm = 10.0;
      indenter.length_mm = 40.0;
      break;
    case Spec::Indenter::kPunch:
      indenter = Object("punch", SceneObject::Shape::kFlatPunch, {0, 0, top + kClearanceMm}, spec.mu);
      indenter.radius_mm = 2.5;
      indenter.edge_radius_mm = 0.75;
      break;
  }
  s.objects.push_back(indenter);
  // Keyframes on whole frames, so the press, the hold and the slide start on a step.
  const double dt = 1.0 / spec.frame_rate_hz;
  const int press = spec.press_frames(), hold = spec.hold_frames(), ramp = spec.ramp_frames();
  const Eigen::Vector3d pressed(0, 0, kClearanceMm + spec.depth_mm());
  Add(s.trajectory, 0.0, {0, 0, 0});
  Add(s.trajectory, press * dt, pressed);
  Add(s.trajectory, (press + hold) * dt, pressed);
  Add(s.trajectory, (press + hold + ramp) * dt, pressed + Eigen::Vector3d(spec.slide_mm(), 0, 0));
  s.trajectory.steps = press + hold + ramp + 1;
  AddLeadIn(s.trajectory);
  s.Validate();
  return s;
}

std::vector<std::string> BuiltInSceneNames() {
  return {"force_calibration", "probe", "pins", "two_material_slide", "bottle",
          "friction_block", "friction_bottle", "friction_paint_can", "friction_tool_handle"};
}

Scene BuiltInScene(const std::string& name) {
  Scene scene;
  if (name == "force_calibration") scene = ForceCalibration();
  else if (name == "probe") scene = Probe();
  else if (name == "pins") scene = Pins();
  else if (name == "two_material_slide") scene = TwoMaterialSlide();
  else if (name == "bottle") scene = Bottle();
  else if (name == "friction_block") scene = FrictionBlock();
  else if (name == "friction_bottle") scene = FrictionBottle();
  else if (name == "friction_paint_can") scene = FrictionPaintCan();
  else if (name == "friction_tool_handle") scene = FrictionToolHandle();
  else if (const auto spec = ParseIncipientSceneName(name)) return IncipientScene(*spec);
  else throw Error(fmt::format("no built-in scene '{}' (there are: {}, and the incipient-slip family "
                               "incipient_<sphere|cylinder|punch>_mu<mu>_<light|heavy>_<slow|fast>[_<rate>hz])",
                               name, fmt::join(BuiltInSceneNames(), ", ")));
  AddLeadIn(scene.trajectory);
  scene.Validate();
  return scene;
}

}  // namespace tac3d
