#pragma once

#include <functional>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <vector>

#include "tac3d/contact/contact_solver.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/scene/scene.h"
#include "tac3d/simulation/gap.h"
#include "tac3d/simulation/twin_body.h"

namespace tac3d {
class MarkerImageRenderer;
}

namespace tac3d::simulation {

/// The contact solver's options for the simulation: tolerances the twin's truth needs (1e-6,
/// relative), not an oracle's (contact's defaults, 1e-8 to 1e-10); measured in
/// docs/simulation.md.
contact::ContactSolverOptions DefaultSimulationContactOptions();

struct SimulationOptions {
  contact::ContactSolverOptions contact = DefaultSimulationContactOptions();
  /// Render each step's camera image (MarkerImageRenderer with the scene's sensor, frame
  /// index = step, so the noise differs per frame).
  bool render_images = true;
  /// The renderer to draw them with, built for RenderedSensor(scene); null: built by the
  /// simulation. Building one (its per-pixel optics) takes ~1 s, more than a short episode's
  /// steps, so simulations of one sensor share it (tac3d.simulate_arrays).
  std::shared_ptr<const MarkerImageRenderer> renderer;
  /// Keep the surface tractions in each TwinStep (TwinStep::surface).
  bool keep_surface = true;
  /// Simulate only the first this many steps (0: all of the trajectory's).
  int max_steps = 0;
  /// A tac3d::ProgressBar on stderr over the steps.
  bool show_progress = false;
  /// The body's Young's modulus relative to the model's. The body is linear elastic, so at a
  /// fixed nu its surface compliance and marker response scale exactly with 1/E: one model
  /// serves a range of E (docs/datasets.md). The contact is displacement-driven, so at scale s
  /// the tractions and forces are s times the model's and the marker displacements the same.
  double youngs_modulus_scale = 1.0;

  /// @throws tac3d::Error naming the field: max_steps >= 0, youngs_modulus_scale in (0, 10],
  ///   the contact options' bounds.
  void Validate() const;
};

/// One step's loads chosen by the caller, a controller closing the loop on what it measured,
/// in place of the trajectory's (TwinSimulation::Step(const StepLoads&)).
struct StepLoads {
  /// The total normal force P (N, >= 0) pressing the object on the fingertip: the step is
  /// force-controlled normally, the pose only places the object (its approach is solved).
  /// 0: nothing touches.
  double normal_force_n = 0.0;
  /// The total tangential force Q (N) the object puts on the fingertip, sensor x-y. Above the
  /// friction capacity the contact slides as a whole (ContactStatus::kGrossSliding).
  Eigen::Vector2d tangential_force_n = Eigen::Vector2d::Zero();

  /// The largest P or |Q| (N): a hundred times a fingertip's range, far past where its linear
  /// elastic model holds; 1e160 N made the solver's arithmetic overflow into a zero force.
  static constexpr double kMaxForceN = 1000.0;

  /// @throws tac3d::Error naming the field: P in [0, kMaxForceN], |Q| <= kMaxForceN.
  void Validate() const;
};

/// The sensor a scene's images are rendered with: its sensor after its manufacturing spread.
SensorConfig RenderedSensor(const Scene& scene);

/// The time between the frames of TwinSimulation::RenderAtRest (s): a camera at 30 Hz.
inline constexpr double kRestFramePeriodS = 1.0 / 30.0;

/// Wall time of a run's phases (s), summed over the steps.
struct SimulationTimings {
  double gap_s = 0.0;       ///< ray casting the gaps and friction
  double contact_s = 0.0;   ///< the contact solves
  double response_s = 0.0;  ///< marker positions, forces, moments
  double render_s = 0.0;    ///< camera images
  double write_s = 0.0;     ///< the dataset writer (or the step callback)
  double total_s = 0.0;
};

struct SimulationSummary {
  int steps = 0;
  /// Steps with at least one node in contact.
  int contact_steps = 0;
  /// Steps whose contact solve did not converge (ContactStatus other than kConverged).
  int non_converged_steps = 0;
  /// Steps under a tangential load above the friction capacity: the contact slid as a whole
  /// (ContactStatus::kGrossSliding, not counted as non-converged).
  int gross_sliding_steps = 0;
  int max_normal_iterations = 0;
  int max_tangential_iterations = 0;
  int max_coupling_iterations = 0;
  /// Steps with contact on the grid's outer row or column (the grid is too small).
  int contact_at_grid_edge_steps = 0;
  double max_cone_violation_mpa = 0.0;
  double max_penetration_mm = 0.0;
  SimulationTimings timings;
};

nlohmann::json ToJson(const SimulationSummary& summary);

/// The twin's quasi-static frictional contact along a scene's trajectory (docs/simulation.md).
/// Step k: the pose world_from_sensor_k; the gap and mu of every contact node by GapCaster;
/// one ContactSolver step (normal: kApproach with delta = 0, the gap holds the penetration;
/// tangential: kShift, the shift accumulating the object's rigid motion relative to the sensor,
/// the increment being the (x, y) motion of the previous step's pressure centroid under
/// sensor_from_world_k * world_from_sensor_{k-1}, zero after a step without contact; under the
/// trajectory's tangential_load, kForce at that load, the object moved by the solved shift); the state of
/// step k - 1 is the history of step k, reset to Unloaded when nothing touches. Then the truth:
/// node tractions in the sensor frame (the object's push on the fingertip: (q_x, q_y, -p)), nodal
/// forces = traction x cell area, marker forces (the sum over a marker's patch), the total
/// force and its moment about the sensor origin (arms = node surface points), marker
/// positions = rest + M f, marker contact and slip flags, and the rendered image.
class TwinSimulation {
 public:
  /// @throws tac3d::Error if the scene or the options are invalid, or the model's body is not
  ///   the scene's marker grid.
  TwinSimulation(const Scene& scene,
                 std::shared_ptr<const TwinBodyModel> model,
                 const SimulationOptions& options = {});
  ~TwinSimulation();

  /// The number of steps Run simulates.
  int num_steps() const;

  /// Simulates the next step (0, 1, ...) and returns its truth; timings accumulate.
  /// @throws tac3d::Error if no step is left.
  TwinStep Step();

  /// Simulates the next step under the caller's loads: the trajectory gives the step's time
  /// and pose (where the object is placed), `loads` the normal and tangential force
  /// (both force-controlled); the object moves by the solved tangential shift, as under a
  /// tangential load ramp. Steps of both kinds may alternate.
  /// @throws tac3d::Error if the loads are invalid (StepLoads::Validate), no step is left,
  ///   the scene's trajectory has a tangential_load (two loads at once), or a normal force
  ///   is asked where no node faces the object.
  TwinStep Step(const StepLoads& loads);

  /// Simulates every remaining step, handing each to `sink` (e.g. TwinDatasetWriter::Write;
  /// its time is the write time).
  SimulationSummary Run(const std::function<void(const TwinStep&)>& sink);

  /// The camera images of the sensor at rest before step 0, what a sensor started up before it
  /// touches anything sees: the markers at their rest positions, the session's conditions at its
  /// start, frames -count .. -1 (each with noise of its own; step k is frame k) at
  /// kRestFramePeriodS apart ending one period before step 0's time. They are what
  /// TwinMeasurement takes as the pipeline's reference. Timings and steps are untouched.
  /// @throws tac3d::Error if count < 1 or the simulation renders no images.
  std::vector<Frame> RenderAtRest(int count) const;

  /// The contact state the next step starts from.
  const contact::ContactState& state() const { return state_; }
  const SimulationSummary& summary() const { return summary_; }
  const TwinBodyModel& model() const { return *model_; }
  /// The surface compliance the contact solver uses (its symbol's eigenvalue report).
  const contact::ConvolutionCompliance& compliance() const { return *compliance_; }

 private:
  /// @throws tac3d::Error if every step is simulated.
  void RequireAStepLeft() const;

  // Step's phases, in order.

  // The object's rigid tangential motion relative to the sensor since the previous step, and
  // remembers this step's pose; zero when the previous step touched nothing (a new contact
  // starts from an undragged surface).
  Eigen::Vector2d TakeTangentialIncrement(const Rigid3& world_from_sensor);
  // One contact solve (or none when nothing touches), folded into the summary; sets state_,
  // writes the solver's report to `solver_json`, returns each node's state.
  // Under the trajectory's tangential load (from its start_s) or the caller's `loads`, the step
  // is force-controlled and the solved shift moves the object (load_shift_mm_).
  std::vector<contact::NodeState> SolveContact(const GapField& gaps,
                                               const Eigen::Vector2d& increment,
                                               double t_s,
                                               const StepLoads* loads,
                                               nlohmann::json* solver_json);
  // Step's body, under the trajectory (`loads` null) or the caller's loads.
  TwinStep SimulateStep(const StepLoads* loads);
  // The truth from state_: nodal forces, their total and moment, marker forces, contact and
  // slip flags, the surface (keep_surface, with each contact node's mu from `gaps`) and the
  // marker positions (rest + M f / youngs_modulus_scale, not crept); sets the pressure
  // centroid for the next step's increment.
  void WriteContactTruth(const std::vector<contact::NodeState>& node_state,
                         const GapField& gaps,
                         TwinStep* out);

  Scene scene_;
  std::shared_ptr<const TwinBodyModel> model_;
  SimulationOptions options_;
  std::shared_ptr<const contact::ConvolutionCompliance> compliance_;
  contact::ContactSolver solver_;
  std::unique_ptr<GapCaster> caster_;
  std::shared_ptr<const MarkerImageRenderer> renderer_;
  std::vector<Eigen::Vector3d> surface_points_;
  std::vector<int> node_markers_;
  contact::ContactState state_;
  Rigid3 previous_pose_ = Rigid3::Identity();
  Eigen::Vector3d previous_centroid_ = Eigen::Vector3d::Zero();
  bool previous_contact_ = false;
  /// The object's tangential motion under the tangential load so far, sensor frame (mm).
  Eigen::Vector2d load_shift_mm_ = Eigen::Vector2d::Zero();
  /// The previous step's friction capacity sum mu p A (N), which a tangential load is of.
  double previous_capacity_n_ = 0.0;
  int next_step_ = 0;
  SimulationSummary summary_;
};

}  // namespace tac3d::simulation
