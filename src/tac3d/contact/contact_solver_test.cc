#include "tac3d/contact/contact_solver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <nlohmann/json.hpp>

#include "tac3d/contact/indenter.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

// A Winkler foundation (independent springs) as a dense compliance: every node's contact
// problem decouples, so the exact solution is known node by node.
constexpr double kNormalCompliance = 0.5;      // mm/MPa
constexpr double kTangentialCompliance = 0.8;  // mm/MPa

std::shared_ptr<const DenseCompliance> Winkler(const SurfaceGrid& grid) {
  const int n = grid.num_nodes();
  Eigen::VectorXd diagonal(3 * n);
  diagonal << Eigen::VectorXd::Constant(2 * n, kTangentialCompliance),
      Eigen::VectorXd::Constant(n, kNormalCompliance);
  return std::make_shared<DenseCompliance>(grid, Eigen::MatrixXd(diagonal.asDiagonal()));
}

Eigen::Vector2d OntoDisk(const Eigen::Vector2d& z, double radius) {
  return z.norm() <= radius ? z : Eigen::Vector2d(z * radius / z.norm());
}

// A sphere on a half-space of silicone, a / h = 8.
struct HalfSpaceCase {
  ElasticMaterial material{1.0, 0.48};
  double radius_mm = 10.0;
  double force_n = 1.0;
  double hertz_radius_mm = std::cbrt(3.0 * force_n * radius_mm * (1.0 - 0.48 * 0.48) / 4.0);
  SurfaceGrid grid{25, 25, hertz_radius_mm / 8.0, hertz_radius_mm / 8.0};
  std::shared_ptr<const HalfSpaceCompliance> compliance =
      std::make_shared<HalfSpaceCompliance>(grid, material);

  ContactStep Press(double mu) const {
    ContactStep step;
    step.gap_mm = Indenter::Sphere(radius_mm).CalcGap(grid, Eigen::Vector2d::Zero());
    step.friction_coefficient = Eigen::VectorXd::Constant(grid.num_nodes(), mu);
    step.normal_force_n = force_n;
    return step;
  }
};

void ExpectContactConditions(const ContactSummary& s) {
  EXPECT_EQ(s.status, ContactStatus::kConverged) << s.message;
  EXPECT_LE(s.max_gap_in_contact_mm, 1e-9);
  EXPECT_LE(s.max_penetration_mm, 1e-9);
  EXPECT_GE(s.min_pressure_mpa, 0.0);
  EXPECT_LE(s.max_cone_violation_mpa, 1e-12);
  EXPECT_LE(s.max_stick_slip_mm, 1e-7);
  EXPECT_LE(s.max_slip_direction_error_rad, 1e-4);
  EXPECT_FALSE(s.contact_at_grid_edge);
}

TEST(ContactSolver, WinklerNormalProblemIsExactUnderBothControls) {
  const SurfaceGrid grid{9, 7, 0.5, 0.5};
  const ContactSolver solver(Winkler(grid));
  ContactStep step;
  step.gap_mm = Indenter::Sphere(4.0).CalcGap(grid, Eigen::Vector2d(0.2, -0.1));
  step.friction_coefficient = Eigen::VectorXd::Constant(grid.num_nodes(), 0.3);
  step.normal_force_n = 0.4;
  const ContactResult r = solver.Solve(step, ContactState::Unloaded(grid.num_nodes()));
  ExpectContactConditions(r.summary);
  EXPECT_NEAR(r.state.normal_force_n, 0.4, 1e-12);
  const Eigen::VectorXd exact =
      (r.state.approach_mm - step.gap_mm.array()).cwiseMax(0.0) / kNormalCompliance;
  EXPECT_THAT(r.state.pressure_mpa, EigenNear(exact, 1e-9));
  EXPECT_GT(r.summary.num_contact, 4);

  step.normal_control = NormalControl::kApproach;
  step.approach_mm = r.state.approach_mm;
  const ContactResult by_approach = solver.Solve(step, ContactState::Unloaded(grid.num_nodes()));
  ExpectContactConditions(by_approach.summary);
  EXPECT_THAT(by_approach.state.pressure_mpa, EigenNear(exact, 1e-9));
}

TEST(ContactSolver, WinklerTangentialProblemIsExactUnderBothControls) {
  const SurfaceGrid grid{9, 9, 0.5, 0.5};
  const ContactSolver solver(Winkler(grid));
  ContactStep step;
  step.gap_mm = Indenter::Sphere(4.0).CalcGap(grid, Eigen::Vector2d::Zero());
  step.friction_coefficient = Eigen::VectorXd::LinSpaced(grid.num_nodes(), 0.2, 0.9);
  step.normal_force_n = 0.5;
  const ContactResult pressed = solver.Solve(step, ContactState::Unloaded(grid.num_nodes()));
  const Eigen::VectorXd& p = pressed.state.pressure_mpa;

  // Shift control: a node sticks to the indenter (q = s / k) or slides at mu p along s.
  step.tangential_control = TangentialControl::kShift;
  step.shift_mm = Eigen::Vector2d(0.03, -0.02);
  const ContactResult sheared = solver.Solve(step, pressed.state);
  ExpectContactConditions(sheared.summary);
  int stick = 0, slip = 0;
  for (int i = 0; i < grid.num_nodes(); ++i) {
    const Eigen::Vector2d exact =
        OntoDisk(step.shift_mm / kTangentialCompliance, step.friction_coefficient[i] * p[i]);
    EXPECT_LE((sheared.state.traction_mpa.row(i).transpose() - exact).norm(), 1e-8) << i;
    if (p[i] > 0.0) (sheared.node_state[i] == NodeState::kStick ? stick : slip) += 1;
  }
  EXPECT_GT(stick, 0);
  EXPECT_GT(slip, 0);

  // Force control with the force that shift produced: the same state and shift back.
  step.tangential_control = TangentialControl::kForce;
  step.tangential_force_n = sheared.state.tangential_force_n;
  const ContactResult by_force = solver.Solve(step, pressed.state);
  ExpectContactConditions(by_force.summary);
  EXPECT_THAT(by_force.state.shift_mm, EigenNear(step.shift_mm, 1e-8));
  EXPECT_THAT(Eigen::MatrixXd(by_force.state.traction_mpa),
              EigenNear(Eigen::MatrixXd(sheared.state.traction_mpa), 1e-7));
}

TEST(ContactSolver, ForceAndApproachControlAgreeOnAHalfSpace) {
  const HalfSpaceCase c;
  const ContactSolver solver(c.compliance);
  ContactStep step = c.Press(0.5);
  const int n = c.grid.num_nodes();
  const ContactResult by_force = solver.Solve(step, ContactState::Unloaded(n));
  ExpectContactConditions(by_force.summary);
  step.normal_control = NormalControl::kApproach;
  step.approach_mm = by_force.state.approach_mm;
  const ContactResult by_approach = solver.Solve(step, ContactState::Unloaded(n));
  ExpectContactConditions(by_approach.summary);
  EXPECT_NEAR(by_approach.state.normal_force_n, c.force_n, 1e-6 * c.force_n);
  // Hertz: delta = a^2 / R within the discretisation error.
  EXPECT_NEAR(by_force.state.approach_mm,
              c.hertz_radius_mm * c.hertz_radius_mm / c.radius_mm,
              0.03 * by_force.state.approach_mm);
}

TEST(ContactSolver, DenseAndFftHalfSpacesGiveTheSameSolution) {
  HalfSpaceCase c;
  c.grid = SurfaceGrid{15, 15, c.hertz_radius_mm / 5.0, c.hertz_radius_mm / 5.0};
  c.compliance = std::make_shared<HalfSpaceCompliance>(c.grid, c.material);
  const auto dense = std::make_shared<DenseCompliance>(c.grid, c.compliance->CalcDenseMatrix());
  ContactStep step = c.Press(0.5);
  step.tangential_force_n = Eigen::Vector2d(0.2, 0.1);
  const int n = c.grid.num_nodes();
  const ContactResult fft = ContactSolver(c.compliance).Solve(step, ContactState::Unloaded(n));
  const ContactResult mat = ContactSolver(dense).Solve(step, ContactState::Unloaded(n));
  ExpectContactConditions(fft.summary);
  ExpectContactConditions(mat.summary);
  EXPECT_THAT(mat.state.pressure_mpa, EigenNear(fft.state.pressure_mpa, 1e-8));
  EXPECT_THAT(Eigen::MatrixXd(mat.state.traction_mpa),
              EigenNear(Eigen::MatrixXd(fft.state.traction_mpa), 1e-6));
}

// The same contact solved on windows around it and on the whole grid (windowed off).
void ExpectTheWholeGridsSolution(const std::shared_ptr<const ComplianceOperator>& compliance,
                                 const ContactStep& step,
                                 int min_attempts) {
  const int n = compliance->grid().num_nodes();
  ContactSolverOptions whole_grid;
  whole_grid.windowed = false;
  const ContactResult windowed = ContactSolver(compliance).Solve(step, ContactState::Unloaded(n));
  const ContactResult whole = ContactSolver(compliance, whole_grid).Solve(step, ContactState::Unloaded(n));
  ExpectContactConditions(windowed.summary);
  EXPECT_LT(windowed.summary.window_nx * windowed.summary.window_ny, n / 2);
  EXPECT_GE(windowed.summary.window_attempts, min_attempts);
  EXPECT_EQ(whole.summary.window_nx, compliance->grid().nx);
  const double p_max = whole.state.pressure_mpa.maxCoeff();
  EXPECT_THAT(windowed.state.pressure_mpa, EigenNear(whole.state.pressure_mpa, 1e-7 * p_max));
  EXPECT_THAT(Eigen::MatrixXd(windowed.state.traction_mpa),
              EigenNear(Eigen::MatrixXd(whole.state.traction_mpa), 1e-6 * p_max));
  EXPECT_THAT(Eigen::MatrixXd(windowed.state.displacement_mm),
              EigenNear(Eigen::MatrixXd(whole.state.displacement_mm),
                        1e-7 * whole.state.displacement_mm.cwiseAbs().maxCoeff()));
  EXPECT_EQ(windowed.summary.num_stick, whole.summary.num_stick);
  EXPECT_EQ(windowed.summary.num_slip, whole.summary.num_slip);
}

TEST(ContactSolver, AWindowAroundTheContactGivesTheWholeGridsSolution) {
  const ElasticMaterial material{1.0, 0.48};
  const SurfaceGrid grid{61, 61, 0.1, 0.1};
  const auto compliance = std::make_shared<HalfSpaceCompliance>(grid, material);
  ContactStep step;
  step.friction_coefficient = Eigen::VectorXd::Constant(grid.num_nodes(), 0.5);
  {
    SCOPED_TRACE("a sphere pressed and sheared by forces, off centre: the first window, the "
                 "nearest node's, grows to hold the contact");
    step.gap_mm = Indenter::Sphere(10.0).CalcGap(grid, Eigen::Vector2d(0.7, -0.4));
    step.normal_force_n = 0.2;
    step.tangential_force_n = Eigen::Vector2d(0.05, 0.03);
    ExpectTheWholeGridsSolution(compliance, step, 2);
  }
  {
    SCOPED_TRACE("two pins far apart, one recessed, under a force: the window around the "
                 "nearer pin grows once the other penetrates");
    step.gap_mm = Indenter::Pins({{{-1.2, 0.3}, 0.3, 0.0}, {{1.2, -0.2}, 0.3, 0.01}})
                      .CalcGap(grid, Eigen::Vector2d::Zero());
    step.normal_force_n = 0.3;
    step.tangential_force_n = Eigen::Vector2d(0.02, 0.0);
    ExpectTheWholeGridsSolution(compliance, step, 2);
  }
}

TEST(ContactSolver, IterationsAddUpOverTheWindowsTried) {
  // Off centre under a force, the first window (the nearest node's) grows at least once. Without
  // coupling each window takes one pass, so the passes count the windows.
  const SurfaceGrid grid{61, 61, 0.1, 0.1};
  const auto compliance = std::make_shared<HalfSpaceCompliance>(grid, ElasticMaterial{1.0, 0.48});
  ContactStep step;
  step.friction_coefficient = Eigen::VectorXd::Constant(grid.num_nodes(), 0.5);
  step.gap_mm = Indenter::Sphere(10.0).CalcGap(grid, Eigen::Vector2d(0.7, -0.4));
  step.normal_force_n = 0.2;
  ContactSolverOptions options;
  options.coupling = Coupling::kNeglect;
  const ContactResult r =
      ContactSolver(compliance, options).Solve(step, ContactState::Unloaded(grid.num_nodes()));
  ExpectContactConditions(r.summary);
  ASSERT_GE(r.summary.window_attempts, 2);
  EXPECT_EQ(r.summary.coupling_iterations, r.summary.window_attempts);
}

// A rigid flat punch of radius a: P = 2 a E* delta (Boussinesq; Johnson, Contact Mechanics, ch. 3).
TEST(ContactSolver, FlatPunchStiffnessIsBoussinesqs) {
  const ElasticMaterial material{1.0, 0.48};
  const double a = 1.0;
  const SurfaceGrid grid{29, 29, a / 12.0, a / 12.0};
  const ContactSolver solver(std::make_shared<HalfSpaceCompliance>(grid, material));
  ContactStep step;
  step.gap_mm = Indenter::FlatPunch(a).CalcGap(grid, Eigen::Vector2d::Zero());
  step.friction_coefficient = Eigen::VectorXd::Zero(grid.num_nodes());
  step.normal_control = NormalControl::kApproach;
  step.approach_mm = 0.1;
  const ContactResult r = solver.Solve(step, ContactState::Unloaded(grid.num_nodes()));
  ExpectContactConditions(r.summary);
  // The punch's area on the grid stands in for pi a^2.
  const double a_grid = std::sqrt(r.summary.num_contact * grid.cell_area_mm2() / std::numbers::pi);
  const double e_star = material.youngs_modulus_mpa / (1.0 - 0.48 * 0.48);
  EXPECT_NEAR(r.state.normal_force_n,
              2.0 * a_grid * e_star * step.approach_mm,
              0.03 * r.state.normal_force_n);
}

TEST(ContactSolver, RecessedPinTouchesOnlyAfterItsRecess) {
  const SurfaceGrid grid{41, 21, 0.1, 0.1};
  const ContactSolver solver(std::make_shared<HalfSpaceCompliance>(grid, ElasticMaterial{}));
  ContactStep step;
  step.gap_mm = Indenter::Pins({{{-1.27, 0.0}, 0.4, 0.0}, {{1.27, 0.0}, 0.4, 0.05}})
                    .CalcGap(grid, Eigen::Vector2d::Zero());
  step.friction_coefficient = Eigen::VectorXd::Zero(grid.num_nodes());
  step.normal_control = NormalControl::kApproach;
  const auto force_on = [&](double approach, double sign) {
    step.approach_mm = approach;
    const ContactResult r = solver.Solve(step, ContactState::Unloaded(grid.num_nodes()));
    ExpectContactConditions(r.summary);
    double f = 0.0;
    for (int i = 0; i < grid.num_nodes(); ++i) {
      if (sign * grid.node_position_mm(i).x() > 0.0)
        f += r.state.pressure_mpa[i] * grid.cell_area_mm2();
    }
    return f;
  };
  // The short pin's own load draws the surface in under the long one: it touches a little after
  // the approach reaches its recess.
  EXPECT_GT(force_on(0.04, -1.0), 0.0);
  EXPECT_EQ(force_on(0.04, 1.0), 0.0);
  EXPECT_GT(force_on(0.08, 1.0), 0.0);
}

// Load then unload a tangential force: the path does not retrace (Mindlin-Deresiewicz), the
// unloaded state keeps a shift and locked-in tractions; the same force from scratch does not.
TEST(ContactSolver, HistoryGivesHysteresis) {
  const HalfSpaceCase c;
  ContactSolverOptions options;
  options.coupling = Coupling::kNeglect;
  const ContactSolver solver(c.compliance, options);
  const int n = c.grid.num_nodes();
  ContactStep step = c.Press(0.5);
  const ContactResult pressed = solver.Solve(step, ContactState::Unloaded(n));
  const double mu_p = 0.5 * c.force_n;
  ContactState state = pressed.state;
  std::vector<double> shifts;
  for (double level : {0.3, 0.6, 0.3, 0.0}) {
    step.tangential_force_n = Eigen::Vector2d(level * mu_p, 0.0);
    const ContactResult r = solver.Solve(step, state);
    ExpectContactConditions(r.summary);
    state = r.state;
    shifts.push_back(state.shift_mm.x());
  }
  EXPECT_GT(shifts[2], 1.1 * shifts[0]);  // unloading lies above loading
  EXPECT_GT(shifts[3], 0.02 * shifts[1]);
  EXPECT_GT(state.traction_mpa.rowwise().norm().maxCoeff(),
            0.05 * mu_p / (c.hertz_radius_mm * c.hertz_radius_mm));
  EXPECT_NEAR(state.tangential_force_n.norm(), 0.0, 1e-9 * mu_p);

  const ContactResult fresh = solver.Solve(step, pressed.state);
  EXPECT_NEAR(fresh.state.shift_mm.norm(), 0.0, 1e-12);
  EXPECT_NEAR(fresh.state.traction_mpa.cwiseAbs().maxCoeff(), 0.0, 1e-12);
}

TEST(ContactSolver, ForceBeyondFrictionIsGrossSliding) {
  const HalfSpaceCase c;
  const ContactSolver solver(c.compliance);
  const int n = c.grid.num_nodes();
  ContactStep step = c.Press(0.4);
  step.tangential_force_n = Eigen::Vector2d(0.0, -0.5 * c.force_n);
  const ContactResult r = solver.Solve(step, ContactState::Unloaded(n));
  EXPECT_EQ(r.summary.status, ContactStatus::kGrossSliding);
  EXPECT_TRUE(r.state.shift_mm.array().isNaN().all());
  EXPECT_NEAR(r.state.tangential_force_n.y(), -0.4 * r.state.normal_force_n, 1e-12);
  EXPECT_NEAR(r.state.tangential_force_n.x(), 0.0, 1e-12);
  EXPECT_THROW(solver.Solve(step, r.state), Error);
}

TEST(ContactSolver, IterationLimitsAreReportedNotHidden) {
  const HalfSpaceCase c;
  const int n = c.grid.num_nodes();
  ContactStep step = c.Press(0.5);
  step.tangential_force_n = Eigen::Vector2d(0.25 * c.force_n, 0.0);

  ContactSolverOptions options;
  options.max_tangential_iterations = 3;
  ContactResult r = ContactSolver(c.compliance, options).Solve(step, ContactState::Unloaded(n));
  EXPECT_EQ(r.summary.status, ContactStatus::kMaxIterations);
  EXPECT_NE(r.summary.message.find("tangential"), std::string::npos) << r.summary.message;
  EXPECT_GT(r.summary.tangential_residual, options.tangential_tolerance);

  options = {};
  options.max_normal_iterations = 2;
  r = ContactSolver(c.compliance, options).Solve(step, ContactState::Unloaded(n));
  EXPECT_EQ(r.summary.status, ContactStatus::kMaxIterations);
  EXPECT_NE(r.summary.message.find("normal"), std::string::npos) << r.summary.message;
  EXPECT_GT(r.summary.normal_residual, options.normal_tolerance);

  options = {};
  options.max_coupling_iterations = 1;
  r = ContactSolver(c.compliance, options).Solve(step, ContactState::Unloaded(n));
  EXPECT_EQ(r.summary.status, ContactStatus::kMaxIterations);
  EXPECT_NE(r.summary.message.find("coupling"), std::string::npos) << r.summary.message;

  r = ContactSolver(c.compliance).Solve(step, ContactState::Unloaded(n));
  ExpectContactConditions(r.summary);
  EXPECT_GT(r.summary.coupling_iterations, 1);  // nu = 0.48 couples the two problems
  const nlohmann::json json = ToJson(r.summary);
  EXPECT_EQ(json.at("status"), "converged");
  EXPECT_EQ(json.at("tangential_iterations"), r.summary.tangential_iterations);
}

TEST(ContactSolver, RejectsBadInput) {
  const HalfSpaceCase c;
  const int n = c.grid.num_nodes();
  const ContactSolver solver(c.compliance);
  const ContactState unloaded = ContactState::Unloaded(n);
  ContactStep step = c.Press(0.5);
  step.normal_force_n = -1.0;
  EXPECT_THROW(solver.Solve(step, unloaded), Error);
  step = c.Press(0.5);
  step.friction_coefficient[3] = -0.1;
  EXPECT_THROW(solver.Solve(step, unloaded), Error);
  step = c.Press(0.5);
  step.gap_mm[0] = NAN;
  EXPECT_THROW(solver.Solve(step, unloaded), Error);
  step = c.Press(0.5);
  step.gap_mm.resize(n - 1);
  EXPECT_THROW(solver.Solve(step, unloaded), Error);
  step = c.Press(0.5);
  step.gap_mm.setConstant(std::numeric_limits<double>::infinity());
  EXPECT_THROW(solver.Solve(step, unloaded), Error);
  EXPECT_THROW(solver.Solve(c.Press(0.5), ContactState::Unloaded(n + 1)), Error);
  EXPECT_THROW(ContactSolver(nullptr), Error);
  ContactSolverOptions options;
  options.tangential_tolerance = 0.0;
  EXPECT_THROW(ContactSolver(c.compliance, options), Error);
  options = {};
  options.max_normal_iterations = 0;
  EXPECT_THROW(ContactSolver(c.compliance, options), Error);
}

}  // namespace
}  // namespace tac3d::contact
