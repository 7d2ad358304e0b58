#include "tac3d/simulation/simulation.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::simulation {
namespace {

using Clock = std::chrono::steady_clock;

// Validated before the members built from them (the scaled compliance).
SimulationOptions Validated(const SimulationOptions& options) {
  options.Validate();
  return options;
}

contact::SampledKernel ScaledKernel(contact::SampledKernel kernel, double factor) {
  for (auto& row : kernel.k) {
    for (Eigen::MatrixXd& k : row) k *= factor;
  }
  return kernel;
}

tac3d::ContactState ToDatasetState(contact::NodeState state) {
  switch (state) {
    case contact::NodeState::kSeparated:
      return tac3d::ContactState::kSeparated;
    case contact::NodeState::kStick:
      return tac3d::ContactState::kStick;
    case contact::NodeState::kSlip:
      return tac3d::ContactState::kSlip;
  }
  return tac3d::ContactState::kSeparated;
}

bool IsNominal(const FrameConditions& c) {
  const FrameConditions nominal;
  return c.illumination_gain == nominal.illumination_gain &&
         c.illumination_offset == nominal.illumination_offset &&
         c.illumination_gradient == nominal.illumination_gradient &&
         c.dot_contrast == nominal.dot_contrast && c.exposure == nominal.exposure &&
         c.creep_mm == nominal.creep_mm;
}

nlohmann::json ConditionsJson(const FrameConditions& c) {
  return {{"illumination_gain", c.illumination_gain},
          {"illumination_offset", c.illumination_offset},
          {"illumination_gradient", c.illumination_gradient},
          {"dot_contrast", c.dot_contrast},
          {"exposure", c.exposure},
          {"creep_mm", {c.creep_mm.x(), c.creep_mm.y(), c.creep_mm.z()}}};
}

// Folds one contact solve's summary into the run's.
void AccumulateSolverSummary(const contact::ContactSummary& s, SimulationSummary* summary) {
  summary->max_normal_iterations = std::max(summary->max_normal_iterations, s.normal_iterations);
  summary->max_tangential_iterations =
      std::max(summary->max_tangential_iterations, s.tangential_iterations);
  summary->max_coupling_iterations =
      std::max(summary->max_coupling_iterations, s.coupling_iterations);
  summary->max_cone_violation_mpa =
      std::max(summary->max_cone_violation_mpa, s.max_cone_violation_mpa);
  summary->max_penetration_mm = std::max(summary->max_penetration_mm, s.max_penetration_mm);
  // Gross sliding is a tangential load's converged answer: the contact slides as a whole.
  if (s.status == contact::ContactStatus::kGrossSliding) ++summary->gross_sliding_steps;
  else if (s.status != contact::ContactStatus::kConverged) ++summary->non_converged_steps;
  if (s.num_contact > 0) {
    ++summary->contact_steps;
    if (s.contact_at_grid_edge) ++summary->contact_at_grid_edge_steps;
  }
}

}  // namespace

SensorConfig RenderedSensor(const Scene& scene) {
  return scene.spread ? PerturbSensor(scene.sensor, *scene.spread) : scene.sensor;
}

contact::ContactSolverOptions DefaultSimulationContactOptions() {
  contact::ContactSolverOptions o;
  o.normal_tolerance = 1e-6;
  o.tangential_tolerance = 1e-6;
  o.coupling_tolerance = 1e-6;
  return o;
}

void SimulationOptions::Validate() const {
  if (max_steps < 0) {
    throw Error(fmt::format("SimulationOptions.max_steps must be >= 0, got {}", max_steps));
  }
  if (!(youngs_modulus_scale > 0.0 && youngs_modulus_scale <= 10.0)) {
    throw Error(fmt::format("SimulationOptions.youngs_modulus_scale must be in (0, 10], got {}",
                            youngs_modulus_scale));
  }
  contact.Validate();
}

void StepLoads::Validate() const {
  if (!(normal_force_n >= 0.0 && normal_force_n <= kMaxForceN)) {
    throw Error(fmt::format("StepLoads.normal_force_n must be in [0, {}] N, got {}",
                            kMaxForceN,
                            normal_force_n));
  }
  if (!(tangential_force_n.allFinite() && tangential_force_n.norm() <= kMaxForceN)) {
    throw Error(fmt::format("StepLoads.tangential_force_n must be at most {} N long, got ({}, {})",
                            kMaxForceN,
                            tangential_force_n.x(),
                            tangential_force_n.y()));
  }
}

nlohmann::json ToJson(const SimulationSummary& s) {
  const SimulationTimings& t = s.timings;
  const double per_step = s.steps > 0 ? 1.0 / s.steps : 0.0;
  return {{"steps", s.steps},
          {"contact_steps", s.contact_steps},
          {"non_converged_steps", s.non_converged_steps},
          {"gross_sliding_steps", s.gross_sliding_steps},
          {"max_normal_iterations", s.max_normal_iterations},
          {"max_tangential_iterations", s.max_tangential_iterations},
          {"max_coupling_iterations", s.max_coupling_iterations},
          {"contact_at_grid_edge_steps", s.contact_at_grid_edge_steps},
          {"max_cone_violation_mpa", s.max_cone_violation_mpa},
          {"max_penetration_mm", s.max_penetration_mm},
          {"timings_s",
           {{"gap", t.gap_s},
            {"contact", t.contact_s},
            {"response", t.response_s},
            {"render", t.render_s},
            {"write", t.write_s},
            {"total", t.total_s}}},
          {"per_step_ms",
           {{"gap", 1e3 * t.gap_s * per_step},
            {"contact", 1e3 * t.contact_s * per_step},
            {"response", 1e3 * t.response_s * per_step},
            {"render", 1e3 * t.render_s * per_step},
            {"write", 1e3 * t.write_s * per_step},
            {"total", 1e3 * t.total_s * per_step}}}};
}

TwinSimulation::TwinSimulation(const Scene& scene,
                               std::shared_ptr<const TwinBodyModel> model,
                               const SimulationOptions& options)
    : scene_(scene),
      model_(std::move(model)),
      options_(Validated(options)),
      compliance_(model_ ? std::make_shared<contact::ConvolutionCompliance>(
                               model_->grid,
                               ScaledKernel(model_->kernel, 1.0 / options.youngs_modulus_scale),
                               model_->options.clamp_floor)
                         : nullptr),
      solver_(compliance_, options.contact) {
  scene_.Validate();
  TAC3D_DEMAND(model_ != nullptr);
  if (model_->body.marker_rows != scene_.sensor.markers.rows ||
      model_->body.marker_cols != scene_.sensor.markers.cols) {
    throw Error(
        fmt::format("TwinSimulation: the twin body has {} x {} markers, the scene's sensor {} x {}",
                    model_->body.marker_rows,
                    model_->body.marker_cols,
                    scene_.sensor.markers.rows,
                    scene_.sensor.markers.cols));
  }
  surface_points_ = model_->CalcNodeSurfacePoints();
  node_markers_ = model_->CalcNodeMarkers();
  caster_ = std::make_unique<GapCaster>(
      scene_.objects, model_->grid, surface_points_, model_->CalcActiveNodes());
  if (options_.render_images) {
    renderer_ = options_.renderer ? options_.renderer
                                  : std::make_shared<const MarkerImageRenderer>(RenderedSensor(scene_));
  }
  state_ = contact::ContactState::Unloaded(model_->grid.num_nodes());
}

TwinSimulation::~TwinSimulation() = default;

int TwinSimulation::num_steps() const {
  const int all = scene_.trajectory.steps;
  return options_.max_steps > 0 ? std::min(all, options_.max_steps) : all;
}

void TwinSimulation::RequireAStepLeft() const {
  if (next_step_ >= num_steps()) {
    throw Error(fmt::format("TwinSimulation::Step: all {} steps of scene '{}' are simulated",
                            num_steps(),
                            scene_.name));
  }
}

TwinStep TwinSimulation::Step() {
  RequireAStepLeft();
  return SimulateStep(nullptr);
}

TwinStep TwinSimulation::Step(const StepLoads& loads) {
  loads.Validate();
  RequireAStepLeft();
  if (scene_.trajectory.tangential_load) {
    throw Error(fmt::format(
        "TwinSimulation::Step: scene '{}' has a trajectory.tangential_load; the caller's loads "
        "replace it, so the scene must not have one",
        scene_.name));
  }
  return SimulateStep(&loads);
}

TwinStep TwinSimulation::SimulateStep(const StepLoads* loads) {
  const auto step_start = Clock::now();
  const int k = next_step_++;
  SimulationTimings& timings = summary_.timings;

  TwinStep out;
  out.index = k;
  out.t_s = scene_.trajectory.StepTime(k);
  // Under a tangential load the object has moved by the solved shifts: the sensor by minus them.
  out.world_from_sensor = scene_.trajectory.PoseAt(out.t_s) *
                          Eigen::Translation3d(-load_shift_mm_.x(), -load_shift_mm_.y(), 0.0);

  auto start = Clock::now();
  const GapField gaps = caster_->Cast(out.world_from_sensor);
  timings.gap_s += SecondsSince(start);

  const Eigen::Vector2d increment = TakeTangentialIncrement(out.world_from_sensor);

  start = Clock::now();
  const std::vector<contact::NodeState> node_state =
      SolveContact(gaps, increment, out.t_s, loads, &out.solver);
  timings.contact_s += SecondsSince(start);

  start = Clock::now();
  WriteContactTruth(node_state, gaps, &out);
  timings.response_s += SecondsSince(start);

  const FrameConditions conditions =
      scene_.conditions.At(out.t_s - scene_.trajectory.keyframes.front().t_s);
  if (renderer_) {
    start = Clock::now();
    out.image = renderer_->Render(out.marker_positions_mm, static_cast<std::uint64_t>(k), conditions);
    timings.render_s += SecondsSince(start);
  }
  // The truth: the markers where the renderer drew them, crept.
  for (Eigen::Vector3d& p : out.marker_positions_mm) p += conditions.creep_mm;
  if (!IsNominal(conditions)) out.conditions = ConditionsJson(conditions);
  ++summary_.steps;
  timings.total_s += SecondsSince(step_start);
  return out;
}

std::vector<Frame> TwinSimulation::RenderAtRest(int count) const {
  if (count < 1) throw Error(fmt::format("TwinSimulation::RenderAtRest: count = {} must be >= 1", count));
  if (!renderer_) {
    throw Error(fmt::format("TwinSimulation::RenderAtRest: scene '{}' is simulated without images",
                            scene_.name));
  }
  const FrameConditions conditions = scene_.conditions.At(0.0);
  const double t0_s = scene_.trajectory.StepTime(0);
  std::vector<Frame> frames(count);
  for (int r = 0; r < count; ++r) {
    Frame& frame = frames[r];
    frame.index = r - count;
    frame.timestamp_s = t0_s + frame.index * kRestFramePeriodS;
    // A negative index wraps to its own noise stream, apart from every step's.
    frame.image = renderer_->Render(model_->marker_positions, static_cast<std::uint64_t>(frame.index), conditions);
  }
  return frames;
}

Eigen::Vector2d TwinSimulation::TakeTangentialIncrement(const Rigid3& world_from_sensor) {
  Eigen::Vector2d increment = Eigen::Vector2d::Zero();
  if (previous_contact_) {
    const Rigid3 motion = world_from_sensor.inverse() * previous_pose_;
    increment = ((motion * previous_centroid_) - previous_centroid_).head<2>();
  }
  previous_pose_ = world_from_sensor;
  return increment;
}

std::vector<contact::NodeState> TwinSimulation::SolveContact(const GapField& gaps,
                                                             const Eigen::Vector2d& increment,
                                                             double t_s,
                                                             const StepLoads* loads,
                                                             nlohmann::json* solver_json) {
  const int n = model_->grid.num_nodes();
  std::vector<contact::NodeState> node_state(n, contact::NodeState::kSeparated);
  const bool touching =
      loads ? loads->normal_force_n > 0.0 : (gaps.gap_mm.array() <= 0.0).any();
  if (!touching) {
    *solver_json = {{"status", "separated"}, {"num_contact", 0}};
    state_ = contact::ContactState::Unloaded(n);
    previous_capacity_n_ = 0.0;
    return node_state;
  }
  contact::ContactStep step;
  step.gap_mm = gaps.gap_mm;
  step.friction_coefficient = gaps.friction_coefficient;
  step.normal_control = contact::NormalControl::kApproach;
  step.approach_mm = 0.0;
  const std::optional<TangentialLoadRamp>& load = scene_.trajectory.tangential_load;
  const bool loaded = loads != nullptr || (load && t_s >= load->start_s);
  if (loads) {
    step.normal_control = contact::NormalControl::kForce;
    step.normal_force_n = loads->normal_force_n;
    step.tangential_control = contact::TangentialControl::kForce;
    step.tangential_force_n = loads->tangential_force_n;
  } else if (loaded) {
    step.tangential_control = contact::TangentialControl::kForce;
    step.tangential_force_n = load->LoadAt(t_s) * previous_capacity_n_ * load->Direction();
  } else {
    step.tangential_control = contact::TangentialControl::kShift;
    step.shift_mm = state_.shift_mm + increment;
  }
  contact::ContactResult result = solver_.Solve(step, state_);
  const contact::ContactSummary& s = result.summary;
  if (loaded && s.num_contact > 0) {
    if (s.status == contact::ContactStatus::kGrossSliding) {
      // A quasi-static slide under a load above the capacity has no determined length: the
      // object is held where it began to slide (its tractions, mu p along the load, are exact).
      result.state.shift_mm = state_.shift_mm;
    } else {
      load_shift_mm_ += result.state.shift_mm - state_.shift_mm;
    }
  }
  *solver_json = contact::ToJson(s);
  AccumulateSolverSummary(s, &summary_);
  if (s.num_contact > 0) {
    node_state = std::move(result.node_state);
    state_ = std::move(result.state);
  } else {
    state_ = contact::ContactState::Unloaded(n);
  }
  // The next step's load is in capacities of this one's: sum mu p A with the mu each node met.
  previous_capacity_n_ = model_->grid.cell_area_mm2() *
                         (gaps.friction_coefficient.array() * state_.pressure_mpa.array()).sum();
  return node_state;
}

void TwinSimulation::WriteContactTruth(const std::vector<contact::NodeState>& node_state,
                                       const GapField& gaps,
                                       TwinStep* out) {
  const TwinBodyModel& model = *model_;
  const int n = model.grid.num_nodes();
  const int num_markers = static_cast<int>(model.marker_positions.size());
  const double area = model.grid.cell_area_mm2();
  const Eigen::Map<const Eigen::MatrixXd> response = model.marker_response.view();
  Eigen::VectorXd displacement = Eigen::VectorXd::Zero(3 * num_markers);
  out->marker_forces_n.assign(num_markers, Eigen::Vector3d::Zero());
  out->marker_contact.assign(num_markers, 0);
  out->marker_slip.assign(num_markers, 0);
  if (options_.keep_surface) {
    out->surface.positions_mm = surface_points_;
    out->surface.tractions_mpa.assign(n, Eigen::Vector3d::Zero());
    out->surface.states.assign(n, tac3d::ContactState::kSeparated);
    out->surface.friction.assign(n, std::numeric_limits<double>::quiet_NaN());
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double weight = 0.0;
  for (int i = 0; i < n; ++i) {
    if (node_state[i] == contact::NodeState::kSeparated) continue;
    const double p = state_.pressure_mpa[i];
    const Eigen::Vector3d traction(state_.traction_mpa(i, 0), state_.traction_mpa(i, 1), -p);
    const Eigen::Vector3d force = area * traction;
    for (int c = 0; c < 3; ++c) displacement += response.col(c * n + i) * force[c];
    out->total_force_n += force;
    out->total_moment_nmm += surface_points_[i].cross(force);
    centroid += p * surface_points_[i];
    weight += p;
    if (const int m = node_markers_[i]; m >= 0) {
      out->marker_forces_n[m] += force;
      out->marker_contact[m] = 1;
      if (node_state[i] == contact::NodeState::kSlip) out->marker_slip[m] = 1;
    }
    if (options_.keep_surface) {
      out->surface.tractions_mpa[i] = traction;
      out->surface.states[i] = ToDatasetState(node_state[i]);
      out->surface.friction[i] = gaps.friction_coefficient[i];
    }
  }
  previous_contact_ = weight > 0.0;
  if (previous_contact_) previous_centroid_ = centroid / weight;
  displacement /= options_.youngs_modulus_scale;
  out->marker_positions_mm.resize(num_markers);
  for (int m = 0; m < num_markers; ++m) {
    out->marker_positions_mm[m] =
        model.marker_positions[m] + Eigen::Vector3d(displacement[m],
                                                    displacement[num_markers + m],
                                                    displacement[2 * num_markers + m]);
  }
}

SimulationSummary TwinSimulation::Run(const std::function<void(const TwinStep&)>& sink) {
  ProgressBar progress("simulate", num_steps(), options_.show_progress);
  while (next_step_ < num_steps()) {
    const TwinStep step = Step();
    if (sink) {
      const auto start = Clock::now();
      sink(step);
      const double write_s = SecondsSince(start);
      summary_.timings.write_s += write_s;
      summary_.timings.total_s += write_s;
    }
    progress.Update(next_step_);
  }
  progress.Finish();
  return summary_;
}

}  // namespace tac3d::simulation
