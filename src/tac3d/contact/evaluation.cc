#include "tac3d/contact/evaluation.h"

#include <cmath>
#include <numbers>

#include "tac3d/contact/indenter.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"

namespace tac3d::contact {
namespace {

constexpr double kPi = std::numbers::pi;

// Hertz, rigid sphere on a half-space (Johnson, Contact Mechanics, ch. 4, with one body
// rigid): a = (3 P R / (4 E*))^(1/3), p0 = 3 P / (2 pi a^2), delta = a^2 / R.
struct Hertz {
  double radius_mm, peak_mpa, approach_mm;
};
Hertz CalcHertz(const EvalContactOptions& o) {
  const double nu = o.material.poisson_ratio;
  const double e_star = o.material.youngs_modulus_mpa / (1.0 - nu * nu);
  const double a = std::cbrt(3.0 * o.normal_force_n * o.sphere_radius_mm / (4.0 * e_star));
  return {a, 3.0 * o.normal_force_n / (2.0 * kPi * a * a), a * a / o.sphere_radius_mm};
}

// Cattaneo-Mindlin (Johnson ch. 7, one body rigid, Goodman's approximation): the shift at which the
// whole contact slides, 3 mu P (2 - nu) / (16 G a), and the shift under Q < mu P.
double FullSlideShift(const EvalContactOptions& o, double mu, double a) {
  return 3.0 * mu * o.normal_force_n * (2.0 - o.material.poisson_ratio) /
         (16.0 * o.material.shear_modulus() * a);
}
double MindlinShift(const EvalContactOptions& o, double q_over_mu_p, double a) {
  return FullSlideShift(o, o.friction_coefficient, a) *
         (1.0 - std::cbrt(std::pow(1.0 - q_over_mu_p, 2.0)));
}

double PercentError(double value, double exact) { return 100.0 * std::abs(value / exact - 1.0); }

// Radius of the circle with the area of the nodes that satisfy `in`.
template <typename Pred>
double EquivalentRadius(const SurfaceGrid& grid, int n, Pred in) {
  int count = 0;
  for (int i = 0; i < n; ++i) count += in(i) ? 1 : 0;
  return std::sqrt(count * grid.cell_area_mm2() / kPi);
}

class Checks {
 public:
  void Add(const std::string& name, double value, double tolerance, const std::string& unit) {
    checks_.push_back(EvalCheck::AtMost(name, value, tolerance, unit));
  }
  const std::vector<EvalCheck>& checks() const { return checks_; }

 private:
  std::vector<EvalCheck> checks_;
};

// The analytic checks of EvaluateContact, one method a phase: Hertz (frictionless press),
// Cattaneo-Mindlin (shear and full slide), Mindlin-Deresiewicz (load history), then sliding
// across two materials. They share one grid, the two solvers, the report and the checks.
class ContactEvaluation {
 public:
  // Sizes the grid for the Hertz contact plus the longest slide.
  explicit ContactEvaluation(const EvalContactOptions& o)
      : o_(o),
        hertz_(CalcHertz(o)),
        // The sliding case moves the sphere by up to 1.5 full-slide shifts of the stickier
        // material.
        max_slide_mm_(1.5 * FullSlideShift(o,
                                           std::max(o.friction_coefficient_left,
                                                    o.friction_coefficient_right),
                                           hertz_.radius_mm)),
        grid_(MakeGrid(o, hertz_, max_slide_mm_)),
        n_(grid_.num_nodes()),
        compliance_(std::make_shared<HalfSpaceCompliance>(grid_, o.material)),
        coupled_solver_(compliance_, WithCoupling(o.solver, Coupling::kFull)),
        goodman_solver_(compliance_, WithCoupling(o.solver, Coupling::kNeglect)),
        sphere_(Indenter::Sphere(o.sphere_radius_mm)) {
    report_["grid"] = {{"nx", grid_.nx},
                       {"ny", grid_.ny},
                       {"spacing_mm", grid_.dx_mm},
                       {"cells_per_radius", o.cells_per_radius}};
  }

  // Hertz: frictionless, so the normal-tangential coupling does not act.
  ContactEvaluation& CheckHertz() {
    const ContactResult pressed =
        coupled_solver_.Solve(Press(Eigen::VectorXd::Zero(n_)), ContactState::Unloaded(n_));
    const Eigen::VectorXd& p = pressed.state.pressure_mpa;
    const double radius = EquivalentRadius(grid_, n_, [&](int i) { return p[i] > 0.0; });
    double sq = 0.0;
    int profile_nodes = 0;
    for (int i = 0; i < n_; ++i) {
      const double r = grid_.node_position_mm(i).norm();
      const double exact =
          r < hertz_.radius_mm
              ? hertz_.peak_mpa * std::sqrt(1.0 - (r * r) / (hertz_.radius_mm * hertz_.radius_mm))
              : 0.0;
      if (exact > 0.0 || p[i] > 0.0) sq += (p[i] - exact) * (p[i] - exact), ++profile_nodes;
    }
    const double profile_rms_pct = 100.0 * std::sqrt(sq / profile_nodes) / hertz_.peak_mpa;
    report_["hertz"] = {{"contact_radius_mm", radius},
                        {"exact_contact_radius_mm", hertz_.radius_mm},
                        {"peak_pressure_mpa", p.maxCoeff()},
                        {"exact_peak_pressure_mpa", hertz_.peak_mpa},
                        {"approach_mm", pressed.state.approach_mm},
                        {"exact_approach_mm", hertz_.approach_mm},
                        {"profile_nodes", profile_nodes},
                        {"summary", Record(pressed)}};
    checks_.Add(
        "hertz_radius_error_pct", PercentError(radius, hertz_.radius_mm), o_.tolerance_pct, "%");
    checks_.Add(
        "hertz_peak_error_pct", PercentError(p.maxCoeff(), hertz_.peak_mpa), o_.tolerance_pct, "%");
    checks_.Add("hertz_profile_rms_pct", profile_rms_pct, o_.tolerance_pct, "% of p0");
    return *this;
  }

  // Cattaneo-Mindlin under Goodman's approximation (its own assumption): Q = 0.5 mu P in one
  // step from the pressed state, then a shift 1.5 x the full-slide shift. Returns the pressed
  // state with friction, from which the load history starts.
  ContactState CheckMindlin() {
    const double mu = o_.friction_coefficient;
    const ContactStep press = Press(Eigen::VectorXd::Constant(n_, mu));
    const ContactResult pressed_mu = goodman_solver_.Solve(press, ContactState::Unloaded(n_));
    ContactStep shear = press;
    shear.tangential_force_n = Eigen::Vector2d(0.5 * mu * o_.normal_force_n, 0.0);
    const ContactResult sheared = goodman_solver_.Solve(shear, pressed_mu.state);
    const double stick_radius = EquivalentRadius(
        grid_, n_, [&](int i) { return sheared.node_state[i] == NodeState::kStick; });
    const double exact_stick = hertz_.radius_mm * std::cbrt(1.0 - 0.5);
    const double exact_shift = MindlinShift(o_, 0.5, hertz_.radius_mm);
    ContactStep slide = press;
    slide.tangential_control = TangentialControl::kShift;
    slide.shift_mm = Eigen::Vector2d(1.5 * FullSlideShift(o_, mu, hertz_.radius_mm), 0.0);
    const ContactResult slid = goodman_solver_.Solve(slide, pressed_mu.state);
    const double slide_ratio =
        slid.state.tangential_force_n.norm() / (mu * slid.state.normal_force_n);
    // For information: the same shear with the coupling kept (nu < 0.5 makes the pressure
    // depend on the shear, which Mindlin's solution ignores).
    const ContactResult sheared_coupled = coupled_solver_.Solve(
        shear, coupled_solver_.Solve(press, ContactState::Unloaded(n_)).state);
    const double coupled_stick_radius = EquivalentRadius(
        grid_, n_, [&](int i) { return sheared_coupled.node_state[i] == NodeState::kStick; });
    report_["mindlin"] = {{"stick_radius_mm", stick_radius},
                          {"coupled_stick_radius_mm", coupled_stick_radius},
                          {"coupled_shift_mm", sheared_coupled.state.shift_mm.x()},
                          {"exact_stick_radius_mm", exact_stick},
                          {"shift_mm", sheared.state.shift_mm.x()},
                          {"exact_shift_mm", exact_shift},
                          {"full_slide_shift_mm", slide.shift_mm.x()},
                          {"full_slide_q_over_mu_p", slide_ratio},
                          {"full_slide_stick_nodes", slid.summary.num_stick},
                          {"summary_pressed", Record(pressed_mu)},
                          {"summary_sheared", Record(sheared)},
                          {"summary_slid", Record(slid)},
                          {"summary_coupled", Record(sheared_coupled)}};
    checks_.Add(
        "mindlin_stick_error_pct", PercentError(stick_radius, exact_stick), o_.tolerance_pct, "%");
    checks_.Add("mindlin_shift_error_pct",
                PercentError(sheared.state.shift_mm.x(), exact_shift),
                o_.tolerance_pct,
                "%");
    checks_.Add("mindlin_full_slide_error_pct",
                100.0 * std::abs(slide_ratio - 1.0),
                o_.friction_tolerance_pct,
                "%");
    return pressed_mu.state;
  }

  // Mindlin-Deresiewicz: Q up to 0.6 mu P and back to 0 in steps, each from the last state.
  // Unloading from Q* the shift is delta(Q*) - 2 delta((Q* - Q) / 2) (Mindlin & Deresiewicz
  // 1953; Johnson ch. 7).
  void CheckHistory(const ContactState& pressed_mu) {
    const double mu = o_.friction_coefficient;
    const ContactStep press = Press(Eigen::VectorXd::Constant(n_, mu));
    const double q_max = 0.6;
    ContactState state = pressed_mu;
    nlohmann::json path = nlohmann::json::array();
    double loading_mid = 0.0, unloading_mid = 0.0;
    for (int k = 1; k <= 2 * kSteps; ++k) {
      const double level = q_max * (k <= kSteps ? k : 2 * kSteps - k) / kSteps;
      ContactStep step = press;
      step.tangential_force_n = Eigen::Vector2d(level * mu * o_.normal_force_n, 0.0);
      const ContactResult r = goodman_solver_.Solve(step, state);
      state = r.state;
      const double exact =
          k <= kSteps ? MindlinShift(o_, level, hertz_.radius_mm)
                      : MindlinShift(o_, q_max, hertz_.radius_mm) -
                            2.0 * MindlinShift(o_, 0.5 * (q_max - level), hertz_.radius_mm);
      if (k == kSteps / 2) loading_mid = state.shift_mm.x();
      if (k == 2 * kSteps - kSteps / 2) unloading_mid = state.shift_mm.x();
      path.push_back({{"q_over_mu_p", level},
                      {"shift_mm", state.shift_mm.x()},
                      {"exact_shift_mm", exact},
                      {"num_stick", r.summary.num_stick},
                      {"num_slip", r.summary.num_slip},
                      {"summary", Record(r)}});
    }
    const double residual_shift = state.shift_mm.x();
    const double exact_residual = path.back().at("exact_shift_mm").get<double>();
    report_["history"] = {
        {"path", path},
        {"residual_shift_mm", residual_shift},
        {"exact_residual_shift_mm", exact_residual},
        {"residual_traction_max_mpa", state.traction_mpa.rowwise().norm().maxCoeff()},
        {"hysteresis_at_half_mm", unloading_mid - loading_mid}};
    checks_.Add("history_residual_shift_error_pct",
                PercentError(residual_shift, exact_residual),
                o_.history_tolerance_pct,
                "%");
  }

  // Sliding across two materials, fully coupled: the sphere moves along x in steps from the
  // pressed state; each node's mu is the object's at the point it faces.
  void CheckTwoMaterial() {
    ContactStep across = Press(MuMap(Eigen::Vector2d::Zero()));
    ContactState state = coupled_solver_.Solve(across, ContactState::Unloaded(n_)).state;
    across.tangential_control = TangentialControl::kShift;
    double max_ratio_error = 0.0;
    int slip_left = 0, slip_right = 0;
    nlohmann::json slide_path = nlohmann::json::array();
    for (int k = 1; k <= kSteps; ++k) {
      const Eigen::Vector2d origin(max_slide_mm_ * k / kSteps, 0.0);
      across.shift_mm = origin;
      across.gap_mm = sphere_.CalcGap(grid_, origin);
      across.friction_coefficient = MuMap(origin);
      const ContactResult r = coupled_solver_.Solve(across, state);
      // Slip from the kinematics (independent of the solver's stick/slip labels).
      const Eigen::MatrixX2d slip =
          (r.state.displacement_mm.leftCols<2>() - state.displacement_mm.leftCols<2>())
              .rowwise() -
          (r.state.shift_mm - state.shift_mm).transpose();
      const double threshold =
          1e-5 * r.state.displacement_mm.leftCols<2>().rowwise().norm().maxCoeff();
      for (int i = 0; i < n_; ++i) {
        const double pi = r.state.pressure_mpa[i];
        if (!(pi > 0.0) || slip.row(i).norm() <= threshold) continue;
        const double m = across.friction_coefficient[i];
        max_ratio_error =
            std::max(max_ratio_error, PercentError(r.state.traction_mpa.row(i).norm() / pi, m));
        (m == o_.friction_coefficient_left ? slip_left : slip_right) += 1;
      }
      state = r.state;
      slide_path.push_back({{"shift_mm", origin.x()},
                            {"tangential_force_n", state.tangential_force_n.x()},
                            {"normal_force_n", state.normal_force_n},
                            {"summary", Record(r)}});
    }
    report_["two_material"] = {{"path", slide_path},
                               {"slip_nodes_left", slip_left},
                               {"slip_nodes_right", slip_right},
                               {"max_ratio_error_pct", max_ratio_error}};
    // Both materials must have slipped for the ratio check to mean anything.
    checks_.Add("slip_mu_error_pct",
                slip_left > 0 && slip_right > 0 ? max_ratio_error : 100.0,
                o_.friction_tolerance_pct,
                "%");
  }

  // Adds the convergence check over every solve and the verdict.
  EvalContactResult Finish() {
    checks_.Add("all_converged", all_converged_ ? 0.0 : 1.0, 0.0, "");
    EvalContactResult result;
    result.checks = checks_.checks();
    result.all_pass = AllPass(result.checks);
    result.details = std::move(report_);
    return result;
  }

 private:
  // Load and history steps of the history and slide phases.
  static constexpr int kSteps = 4;

  static SurfaceGrid MakeGrid(const EvalContactOptions& o, const Hertz& hertz, double max_slide) {
    const double spacing = hertz.radius_mm / o.cells_per_radius;
    const int half = static_cast<int>(std::ceil((1.3 * hertz.radius_mm + max_slide) / spacing));
    return SurfaceGrid{2 * half + 1, 2 * half + 1, spacing, spacing};
  }
  static ContactSolverOptions WithCoupling(ContactSolverOptions options, Coupling coupling) {
    options.coupling = coupling;
    return options;
  }

  // The sphere pressed at the origin by the normal force, with friction `mu` at each node.
  ContactStep Press(const Eigen::VectorXd& mu) const {
    ContactStep press;
    press.gap_mm = sphere_.CalcGap(grid_, Eigen::Vector2d::Zero());
    press.normal_force_n = o_.normal_force_n;
    press.friction_coefficient = mu;
    return press;
  }

  // Each node's mu: the left material's where it faces x < 0 relative to `origin`.
  Eigen::VectorXd MuMap(const Eigen::Vector2d& origin) const {
    Eigen::VectorXd m(n_);
    for (int i = 0; i < n_; ++i) {
      m[i] = (grid_.node_position_mm(i) - origin).x() < 0.0 ? o_.friction_coefficient_left
                                                            : o_.friction_coefficient_right;
    }
    return m;
  }

  // Notes whether the solve converged away from the grid's edge; its summary for the report.
  nlohmann::json Record(const ContactResult& r) {
    all_converged_ = all_converged_ && r.summary.status != ContactStatus::kMaxIterations &&
                     !r.summary.contact_at_grid_edge;
    return ToJson(r.summary);
  }

  const EvalContactOptions& o_;
  const Hertz hertz_;
  const double max_slide_mm_;
  const SurfaceGrid grid_;
  const int n_;
  const std::shared_ptr<const HalfSpaceCompliance> compliance_;
  const ContactSolver coupled_solver_;
  const ContactSolver goodman_solver_;
  const Indenter sphere_;
  Checks checks_;
  bool all_converged_ = true;
  nlohmann::json report_;
};

}  // namespace

void EvalContactOptions::Validate() const {
  const auto positive = [](const char* name, double v) {
    if (!(v > 0.0 && std::isfinite(v))) {
      throw Error(fmt::format("EvalContactOptions.{} must be > 0, got {}", name, v));
    }
  };
  positive("sphere_radius_mm", sphere_radius_mm);
  positive("normal_force_n", normal_force_n);
  positive("friction_coefficient", friction_coefficient);
  positive("friction_coefficient_left", friction_coefficient_left);
  positive("friction_coefficient_right", friction_coefficient_right);
  positive("tolerance_pct", tolerance_pct);
  positive("friction_tolerance_pct", friction_tolerance_pct);
  positive("history_tolerance_pct", history_tolerance_pct);
  if (!(cells_per_radius >= 4.0 && cells_per_radius <= 64.0)) {
    throw Error(fmt::format("EvalContactOptions.cells_per_radius must be in [4, 64], got {}",
                            cells_per_radius));
  }
  material.Validate();
  solver.Validate();
}

std::string EvalContactResult::Report() const {
  std::string text = FormatChecks(checks);
  return text + fmt::format("all pass: {}\n", all_pass ? "yes" : "no");
}

nlohmann::json ToJson(const EvalContactResult& result) {
  nlohmann::json json = result.details;
  json["checks"] = ToJson(result.checks);
  json["all_pass"] = result.all_pass;
  return json;
}

EvalContactResult EvaluateContact(const EvalContactOptions& o) {
  o.Validate();
  ContactEvaluation evaluation(o);
  const ContactState pressed_mu = evaluation.CheckHertz().CheckMindlin();
  evaluation.CheckHistory(pressed_mu);
  evaluation.CheckTwoMaterial();
  return evaluation.Finish();
}

}  // namespace tac3d::contact
