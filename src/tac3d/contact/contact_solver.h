#pragma once

#include <Eigen/Core>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/contact/compliance.h"

namespace tac3d::contact {

/// How the normal problem is loaded: the total normal force P, or the rigid approach delta.
enum class NormalControl { kForce, kApproach };
/// How the tangential problem is loaded: the total tangential force Q, or the indenter's rigid
/// tangential displacement s (the shift), absolute in the frame of the previous state's shift.
enum class TangentialControl { kForce, kShift };
/// kFull solves the normal and tangential problems together through the compliance's coupling
/// blocks (Kalker's / Panagiotopoulos' alternation); kNeglect drops those blocks (Goodman's
/// approximation, the assumption behind Cattaneo-Mindlin; exact for nu = 0.5).
enum class Coupling { kFull, kNeglect };

struct ContactSolverOptions {
  Coupling coupling = Coupling::kFull;
  /// Normal/tangential alternations (kFull only), and iterations of each sub-solver per pass.
  int max_coupling_iterations = 30;
  int max_normal_iterations = 2000;
  int max_tangential_iterations = 20000;
  /// Normal: Polonsky & Keer's criterion, sum |p_new - p_old| / sum p.
  double normal_tolerance = 1e-10;
  /// Tangential: the largest KKT residual (projected-gradient fixed-point residual, mm) over
  /// the largest tangential displacement.
  double tangential_tolerance = 1e-8;
  /// kFull: stop alternating when tractions change by less than this (relative, L1).
  double coupling_tolerance = 1e-8;
  /// Solve on a window of the grid around the contact when the compliance has windows
  /// (ComplianceOperator::Window): the same solution, the window grown until the contact lies
  /// inside its border and no node outside penetrates, at the cost of the window's size
  /// instead of the grid's.
  bool windowed = true;

  /// @throws tac3d::Error naming the field: iteration limits >= 1, tolerances in (0, 1).
  void Validate() const;
};

/// One quasi-static step's loading.
struct ContactStep {
  /// h at every node (mm), Indenter::CalcGap: finite, or +infinity where nothing can touch.
  Eigen::VectorXd gap_mm;
  /// Coulomb friction coefficient mu at every node (>= 0): the object's friction map sampled
  /// at the point of the object each node faces in this step.
  Eigen::VectorXd friction_coefficient;
  NormalControl normal_control = NormalControl::kForce;
  /// kForce: the total normal force P (N, >= 0).
  double normal_force_n = 0.0;
  /// kApproach: the rigid approach delta (mm): how far the indenter's reference point has
  /// moved into the undeformed surface.
  double approach_mm = 0.0;
  TangentialControl tangential_control = TangentialControl::kForce;
  /// kForce: the total tangential force Q (N) the indenter puts on the body.
  Eigen::Vector2d tangential_force_n = Eigen::Vector2d::Zero();
  /// kShift: the indenter's rigid tangential displacement s (mm).
  Eigen::Vector2d shift_mm = Eigen::Vector2d::Zero();

  /// @throws tac3d::Error naming the field: sizes n, gap not NaN or -inf, mu finite >= 0,
  ///   P finite >= 0, approach, Q and s finite.
  void Validate(int num_nodes) const;
};

/// The contact's state after a step; the next step starts from it (history).
struct ContactState {
  /// Pressure p (MPa, >= 0) on every node.
  Eigen::VectorXd pressure_mpa;
  /// Tangential traction q (MPa) the indenter puts on the body, n x 2.
  Eigen::MatrixX2d traction_mpa;
  /// Surface displacement (mm), n x 3: x, y, normal (into the body).
  Eigen::MatrixX3d displacement_mm;
  /// The slip increment of this step, n x 2 (mm): the body's surface point relative to the
  /// indenter's; zero where separated, zero to the solver's tolerance in stick.
  Eigen::MatrixX2d slip_mm;
  double approach_mm = 0.0;
  Eigen::Vector2d shift_mm = Eigen::Vector2d::Zero();
  double normal_force_n = 0.0;
  Eigen::Vector2d tangential_force_n = Eigen::Vector2d::Zero();

  /// Nothing touching, nothing displaced: the start of a trajectory.
  static ContactState Unloaded(int num_nodes);
};

enum class NodeState { kSeparated, kStick, kSlip };

enum class ContactStatus {
  kConverged,
  /// Force control with |Q| >= the friction capacity sum mu p A: the indenter slides off and
  /// the quasi-static shift is undetermined (shift and slip are NaN, q = mu p Q / |Q|).
  kGrossSliding,
  /// An iteration limit was reached; the summary's residuals say how far from converged.
  kMaxIterations,
};
std::string ToString(ContactStatus status);

/// What the solver did and how well the returned state satisfies the contact conditions.
struct ContactSummary {
  ContactStatus status = ContactStatus::kConverged;
  std::string message;
  /// Iterations, summed over the window attempts (each attempt solves its window again,
  /// warm-started from the last): normal-tangential alternations, and the normal and
  /// tangential sub-solvers' iterations over all those alternations. Each attempt has the
  /// options' limits of its own.
  int coupling_iterations = 0;
  int normal_iterations = 0;
  int tangential_iterations = 0;
  /// The last pass' criteria (see ContactSolverOptions).
  double normal_residual = 0.0;
  double tangential_residual = 0.0;
  double coupling_change = 0.0;
  /// Checks on the returned state, gap g = h + u_normal - delta:
  double max_gap_in_contact_mm = 0.0;       // max |g| where p > 0 (0 exactly)
  double max_penetration_mm = 0.0;          // max(0, -g) (non-penetration)
  double max_complementarity_mpa_mm = 0.0;  // max p |g|
  double min_pressure_mpa = 0.0;            // (>= 0)
  double max_cone_violation_mpa = 0.0;      // max(0, |q| - mu p)
  double max_stick_slip_mm = 0.0;           // max |slip| on stick nodes (0 exactly)
  /// Largest angle between q and -slip on nodes slipping more than 1e-3 of the largest slip.
  double max_slip_direction_error_rad = 0.0;
  int num_contact = 0;
  int num_stick = 0;
  int num_slip = 0;
  /// A contact node on the grid's outer row or column: the grid is too small for the contact.
  bool contact_at_grid_edge = false;
  /// The last window the tractions were solved on (nodes along x and y; the grid's size when
  /// solved on the whole grid), and how many windows were tried (1 + the times one grew).
  int window_nx = 0;
  int window_ny = 0;
  int window_attempts = 0;
  double time_s = 0.0;
};
nlohmann::json ToJson(const ContactSummary& summary);

struct ContactResult {
  ContactState state;
  std::vector<NodeState> node_state;
  ContactSummary summary;
};

/// Quasi-static frictional contact of a rigid indenter on an elastic surface with any linear
/// compliance (ComplianceOperator), one load step at a time.
/// Normal problem: Polonsky & Keer's constrained conjugate gradients (Wear 231, 1999), force
/// or approach controlled. Tangential problem: Kalker's minimum of complementary energy for a
/// time step (Three-Dimensional Elastic Bodies in Rolling Contact, 1990, ch. 2-3):
///   min_q 1/2 q.C_tt q + q.(C_tn p - u_prev - s_increment)  subject to |q_i| <= mu_i p_i
/// (with sum q A = Q instead of s for force control), whose optimality conditions are Coulomb's
/// law with the slip increment relative to the previous step; solved by accelerated projected
/// gradients (FISTA, Beck & Teboulle 2009, with O'Donoghue & Candes' adaptive restart).
class ContactSolver {
 public:
  /// @throws tac3d::Error if the compliance is null or the options are invalid.
  explicit ContactSolver(std::shared_ptr<const ComplianceOperator> compliance,
                         const ContactSolverOptions& options = {});

  /// Solves one step starting from `previous` (its tractions warm-start the iterations, its
  /// displacement and shift define the slip increments).
  /// @throws tac3d::Error if the step or the previous state does not fit the grid.
  ContactResult Solve(const ContactStep& step, const ContactState& previous) const;

  const ComplianceOperator& compliance() const { return *compliance_; }

 private:
  struct WindowCache;
  // The compliance on an nx x ny window, made once per size (null without windows).
  std::shared_ptr<const ComplianceOperator> WindowCompliance(int nx, int ny) const;

  std::shared_ptr<const ComplianceOperator> compliance_;
  ContactSolverOptions options_;
  std::shared_ptr<WindowCache> windows_;
};

}  // namespace tac3d::contact
