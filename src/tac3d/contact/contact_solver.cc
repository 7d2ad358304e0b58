#include "tac3d/contact/contact_solver.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <utility>

#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::contact {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A node is slipping when |q| reaches mu p to this relative precision (the projection puts
// slipping nodes exactly on the cone; stick nodes converge strictly inside it).
constexpr double kOnCone = 1e-6;

double RelativeL1Change(const Eigen::MatrixXd& now, const Eigen::MatrixXd& before) {
  const double size = now.cwiseAbs().sum();
  return size > 0.0 ? (now - before).cwiseAbs().sum() / size : 0.0;
}

struct SubSolve {
  int iterations = 0;
  double residual = 0.0;
  bool converged = false;
};

// Polonsky & Keer's constrained conjugate gradients (Wear 231 (1999) 206-219, section 3): CG on
// the nodes in contact for C p = delta - h, pressures that go negative leave the contact set,
// penetrating separated nodes join it (and restart the conjugacy). Under force control the
// approach is the mean gap over the contact set and the pressures are rescaled to P each
// iteration.
class NormalProblem {
 public:
  NormalProblem(const ComplianceOperator& c,
                const Eigen::VectorXd& h,
                const std::vector<char>& candidate,
                const ContactStep& step,
                const ContactSolverOptions& options)
      : c_(c),
        h_(h),
        candidate_(candidate),
        force_control_(step.normal_control == NormalControl::kForce),
        target_(force_control_ ? step.normal_force_n / c.grid().cell_area_mm2() : 0.0),
        approach_(force_control_ ? 0.0 : step.approach_mm),
        options_(options) {}

  // Solves in place, starting from p.
  SubSolve Solve(Eigen::VectorXd& p) {
    const int n = static_cast<int>(p.size());
    SubSolve result;
    if (force_control_ && target_ == 0.0) {
      p.setZero();
      result.converged = true;
      return result;
    }
    if (force_control_ && p.sum() <= 0.0) SeedUniform(p);
    Eigen::VectorXd t = Eigen::VectorXd::Zero(n), g(n), p_old;
    double g_norm_old = 1.0;
    bool conjugate = false;
    for (result.iterations = 1; result.iterations <= options_.max_normal_iterations;
         ++result.iterations) {
      g = Gap(p);
      int num_contact = 0;
      double mean = 0.0;
      for (int i = 0; i < n; ++i) {
        if (p[i] > 0.0) mean += g[i], ++num_contact;
      }
      if (num_contact == 0) {
        // Approach control only (force control keeps sum p = P): restart from the overlap.
        if (!SeedFromOverlap(g, p)) {
          result.converged = true;
          return result;
        }
        conjugate = false;
        continue;
      }
      // Force control: the approach is the mean of h + u over the contact set.
      if (force_control_) g.array() -= mean / num_contact;
      double g_norm = 0.0;
      for (int i = 0; i < n; ++i) {
        if (p[i] > 0.0) g_norm += g[i] * g[i];
      }
      for (int i = 0; i < n; ++i) {
        t[i] = p[i] > 0.0 ? g[i] + (conjugate ? g_norm / g_norm_old : 0.0) * t[i] : 0.0;
      }
      g_norm_old = g_norm;
      Eigen::VectorXd r = c_.Apply(Components::kNormal, Components::kNormal, t);
      if (force_control_) {
        double r_mean = 0.0;
        for (int i = 0; i < n; ++i) {
          if (p[i] > 0.0) r_mean += r[i];
        }
        r.array() -= r_mean / num_contact;
      }
      double gt = 0.0, rt = 0.0;
      for (int i = 0; i < n; ++i) {
        if (p[i] > 0.0) gt += g[i] * t[i], rt += r[i] * t[i];
      }
      if (!(rt > 0.0)) {  // t = 0: the gap is already closed on the contact set
        result.converged = true;
        return result;
      }
      const double tau = gt / rt;
      p_old = p;
      bool overlap = false;
      for (int i = 0; i < n; ++i) {
        if (p[i] > 0.0) {
          p[i] = std::max(p[i] - tau * t[i], 0.0);
        } else if (candidate_[i] && g[i] < 0.0) {
          p[i] = -tau * g[i];
          overlap = true;
        }
      }
      conjugate = !overlap;
      if (force_control_) {
        const double sum = p.sum();
        if (sum > 0.0) {
          p *= target_ / sum;
        } else {  // every node left the contact set: start again
          SeedUniform(p);
          conjugate = false;
        }
      }
      result.residual = RelativeL1Change(p, p_old);
      if (result.residual < options_.normal_tolerance) {
        result.converged = true;
        return result;
      }
    }
    result.iterations = options_.max_normal_iterations;
    return result;
  }

 private:
  Eigen::VectorXd Gap(const Eigen::VectorXd& p) const {
    Eigen::VectorXd g = c_.Apply(Components::kNormal, Components::kNormal, p);
    g += h_;
    g.array() -= approach_;
    return g;
  }

  // Force control: P spread evenly over the nodes that can touch (Polonsky & Keer's start).
  void SeedUniform(Eigen::VectorXd& p) const {
    for (int i = 0; i < p.size(); ++i) p[i] = candidate_[i] ? 1.0 : 0.0;
    p *= target_ / p.sum();
  }

  // p proportional to the penetration, scaled to fit C p = penetration in the least-squares
  // sense; false if nothing penetrates.
  bool SeedFromOverlap(const Eigen::VectorXd& g, Eigen::VectorXd& p) const {
    p = (-g).cwiseMax(0.0);
    for (int i = 0; i < p.size(); ++i) {
      if (!candidate_[i]) p[i] = 0.0;
    }
    if (p.sum() <= 0.0) return false;
    const Eigen::VectorXd cp = c_.Apply(Components::kNormal, Components::kNormal, p);
    p *= p.squaredNorm() / cp.dot(p);
    return true;
  }

  const ComplianceOperator& c_;
  const Eigen::VectorXd& h_;
  const std::vector<char>& candidate_;
  const bool force_control_;
  const double target_;    // P / A: the sum of nodal pressures
  const double approach_;  // approach control; 0 under force control
  const ContactSolverOptions& options_;
};

// The approach consistent with the tractions: given, or under force control the mean of
// h + u_normal over the contact set (zero gap there); with no contact, the approach at which
// the indenter just touches.
double CalcApproach(const ContactStep& step,
                    const Eigen::VectorXd& p,
                    const Eigen::VectorXd& h,
                    const std::vector<char>& candidate,
                    const Eigen::VectorXd& u_normal) {
  if (step.normal_control == NormalControl::kApproach) return step.approach_mm;
  double sum = 0.0, touch = std::numeric_limits<double>::infinity();
  int count = 0;
  for (int i = 0; i < p.size(); ++i) {
    if (p[i] > 0.0) sum += h[i] + u_normal[i], ++count;
    if (candidate[i]) touch = std::min(touch, h[i]);
  }
  return count > 0 ? sum / count : touch;
}

// The tangential problem of one step for a fixed pressure: minimise
// f(q) = 1/2 q.C_tt q + q.b over |q_i| <= bound_i (and sum q = Q / A under force control).
// grad f = slip increment (plus the shift increment under force control), so the KKT
// conditions are Coulomb's law.
class TangentialProblem {
 public:
  TangentialProblem(const ComplianceOperator& c,
                    const Eigen::VectorXd& bound,
                    const Eigen::MatrixX2d& b,
                    const ContactStep& step,
                    const ContactSolverOptions& options)
      : c_(c),
        bound_(bound),
        b_(b),
        force_control_(step.tangential_control == TangentialControl::kForce),
        target_(step.tangential_force_n / c.grid().cell_area_mm2()),
        options_(options) {}

  // True if the force exceeds the friction capacity: q is then mu p in the force's direction.
  bool GrossSliding(Eigen::MatrixX2d& q) const {
    const double force = target_.norm();
    if (!force_control_ || force == 0.0 || force < (1.0 - 1e-9) * bound_.sum()) return false;
    q = bound_ * (target_ / target_.norm()).transpose();
    return true;
  }

  // `lipschitz`: the step bound L; estimated if <= 0, and returned (as backtracking left it)
  // for the next coupling pass, whose operator is the same on a similar contact set.
  SubSolve Solve(Eigen::MatrixX2d& q, double& lipschitz) {
    SubSolve result;
    Eigen::MatrixX2d x = Project(q);
    Eigen::MatrixX2d cx = Apply(x), y = x, cy = cx, x_new, cx_new;
    if (lipschitz <= 0.0) lipschitz = EstimateLipschitz();
    double theta = 1.0;
    for (result.iterations = 1; result.iterations <= options_.max_tangential_iterations;
         ++result.iterations) {
      const Eigen::MatrixX2d grad_y = cy + b_;
      for (;;) {  // backtracking: the step 1 / L must not exceed 1 / lambda_max on this step
        x_new = Project(y - grad_y / lipschitz);
        cx_new = Apply(x_new);
        const Eigen::MatrixX2d d = x_new - y;
        if ((d.array() * (cx_new - cy).array()).sum() <=
            lipschitz * d.squaredNorm() * (1 + 1e-12)) {
          break;
        }
        lipschitz *= 2.0;
      }
      // KKT residual: the projected-gradient step at x_new, in displacement units.
      const Eigen::MatrixX2d grad_x = cx_new + b_;
      const double residual =
          (x_new - Project(x_new - grad_x / lipschitz)).rowwise().norm().maxCoeff() * lipschitz;
      const double scale = std::max({cx_new.rowwise().norm().maxCoeff(),
                                     b_.rowwise().norm().maxCoeff(),
                                     std::numeric_limits<double>::min()});
      result.residual = residual / scale;
      if (result.residual <= options_.tangential_tolerance) {
        q = x_new;
        result.converged = true;
        return result;
      }
      if (((y - x_new).array() * (x_new - x).array()).sum() > 0.0) {
        theta = 1.0;  // momentum is pointing uphill: restart
        y = x_new;
        cy = cx_new;
      } else {
        const double theta_new = 0.5 * (1.0 + std::sqrt(1.0 + 4.0 * theta * theta));
        const double beta = (theta - 1.0) / theta_new;
        y = x_new + beta * (x_new - x);
        cy = cx_new + beta * (cx_new - cx);
        theta = theta_new;
      }
      x = x_new;
      cx = cx_new;
    }
    result.iterations = options_.max_tangential_iterations;
    q = x;
    return result;
  }

 private:
  Eigen::MatrixX2d Apply(const Eigen::MatrixX2d& q) const {
    return c_.Apply(Components::kTangential, Components::kTangential, q);
  }

  static Eigen::Vector2d OntoDisk(const Eigen::Vector2d& z, double radius) {
    const double norm = z.norm();
    return norm <= radius ? z : Eigen::Vector2d(z * (radius / norm));
  }

  // Euclidean projection onto the friction disks (and, under force control, the plane
  // sum q = Q / A): q_i = onto disk_i(z_i + lambda), lambda the plane's multiplier.
  Eigen::MatrixX2d Project(const Eigen::MatrixX2d& z) {
    if (force_control_) lambda_ = SolveMultiplier(z);
    Eigen::MatrixX2d q(z.rows(), 2);
    for (int i = 0; i < z.rows(); ++i) {
      const Eigen::Vector2d zi = z.row(i).transpose() + lambda_;
      q.row(i) = bound_[i] > 0.0 ? Eigen::RowVector2d(OntoDisk(zi, bound_[i]).transpose())
                                 : Eigen::RowVector2d::Zero();
    }
    return q;
  }

  // lambda minimises the convex phi(lambda) = sum_i e_i(z_i + lambda) - target . lambda, e_i
  // the Huber-like envelope of disk i, whose gradient is sum_i onto disk_i(z_i + lambda) - target:
  // damped Newton from the previous multiplier.
  Eigen::Vector2d SolveMultiplier(const Eigen::MatrixX2d& z) const {
    const auto phi =
        [&](const Eigen::Vector2d& lambda, Eigen::Vector2d* grad, Eigen::Matrix2d* hess) {
          double value = -target_.dot(lambda);
          if (grad) *grad = -target_;
          if (hess) hess->setZero();
          for (int i = 0; i < z.rows(); ++i) {
            const double g = bound_[i];
            if (g <= 0.0) continue;
            const Eigen::Vector2d y = z.row(i).transpose() + lambda;
            const double norm = y.norm();
            if (norm <= g) {
              value += 0.5 * norm * norm;
              if (grad) *grad += y;
              if (hess) *hess += Eigen::Matrix2d::Identity();
            } else {
              value += g * norm - 0.5 * g * g;
              const Eigen::Vector2d n = y / norm;
              if (grad) *grad += g * n;
              if (hess) *hess += (g / norm) * (Eigen::Matrix2d::Identity() - n * n.transpose());
            }
          }
          return value;
        };
    const double scale = bound_.sum() + target_.norm();
    Eigen::Vector2d lambda = lambda_, grad;
    Eigen::Matrix2d hess;
    // phi is piecewise quadratic: Newton ends once the set of clipped nodes settles. A step is
    // accepted if it decreases phi enough or halves the gradient (near the solution phi's
    // decrease drowns in its rounding while the gradient's does not).
    for (int k = 0; k < 50; ++k) {
      const double value = phi(lambda, &grad, &hess);
      if (grad.norm() <= 1e-13 * scale) break;
      hess.diagonal().array() += 1e-12 * (hess.trace() + 1.0);
      const Eigen::Vector2d step = -hess.ldlt().solve(grad);
      Eigen::Vector2d grad_new;
      double t = 1.0;
      for (; t > 1e-12; t *= 0.5) {
        const double value_new = phi(lambda + t * step, &grad_new, nullptr);
        if (value_new <= value + 1e-4 * t * grad.dot(step) ||
            grad_new.norm() <= 0.5 * grad.norm()) {
          break;
        }
      }
      if (t <= 1e-12) break;  // no progress left at rounding level
      lambda += t * step;
    }
    return lambda;
  }

  // Power iteration for the largest eigenvalue of C_tt on the nodes that can carry traction,
  // with a margin; backtracking corrects an underestimate.
  double EstimateLipschitz() const {
    Eigen::MatrixX2d v(bound_.size(), 2);
    for (int i = 0; i < v.rows(); ++i) {
      v.row(i) =
          bound_[i] > 0.0 ? Eigen::RowVector2d(1.0, 0.5 + (i % 3)) : Eigen::RowVector2d::Zero();
    }
    if (v.squaredNorm() == 0.0) return 1.0;
    double lambda = 0.0;
    for (int k = 0; k < 20; ++k) {
      v /= v.norm();
      Eigen::MatrixX2d w = Apply(v);
      for (int i = 0; i < w.rows(); ++i) {
        if (bound_[i] <= 0.0) w.row(i).setZero();
      }
      lambda = (w.array() * v.array()).sum();
      v = w;
    }
    return 1.1 * lambda;
  }

  const ComplianceOperator& c_;
  const Eigen::VectorXd& bound_;
  const Eigen::MatrixX2d& b_;
  const bool force_control_;
  const Eigen::Vector2d target_;  // Q / A: the sum of nodal tractions
  const ContactSolverOptions& options_;
  Eigen::Vector2d lambda_ = Eigen::Vector2d::Zero();
};

void RequireRows(const char* what, Eigen::Index rows, int n) {
  if (rows != n)
    throw Error(fmt::format("ContactState.{} has {} rows, the grid {} nodes", what, rows, n));
}

// The previous state must be on the solver's grid and not have slid off.
void RequirePreviousState(const ContactState& previous, int n) {
  RequireRows("pressure_mpa", previous.pressure_mpa.size(), n);
  RequireRows("traction_mpa", previous.traction_mpa.rows(), n);
  RequireRows("displacement_mm", previous.displacement_mm.rows(), n);
  if (!previous.shift_mm.allFinite()) {
    throw Error("ContactState.shift_mm is not finite (the previous step slid off)");
  }
}

// The nodes that face the indenter (finite gap); a normal force needs at least one.
std::vector<char> CandidateNodes(const ContactStep& step) {
  const int n = static_cast<int>(step.gap_mm.size());
  std::vector<char> candidate(n);
  for (int i = 0; i < n; ++i) candidate[i] = std::isfinite(step.gap_mm[i]);
  if (step.normal_control == NormalControl::kForce && step.normal_force_n > 0.0 &&
      std::find(candidate.begin(), candidate.end(), 1) == candidate.end()) {
    throw Error("ContactStep: a normal force but no node faces the indenter (gap all infinite)");
  }
  return candidate;
}

// What a step fixes for the sub-problems, on the grid or on a window of it.
struct StepInputs {
  ContactStep step;
  // The gap with a finite stand-in where it is infinite, and the nodes where it is finite.
  Eigen::VectorXd h;
  std::vector<char> candidate;
  // The previous state's tangential displacement, and the indenter's shift increment (zero
  // under force control).
  Eigen::MatrixX2d u_t_prev;
  Eigen::Vector2d shift_increment;

  // The inputs of the window whose node k is this one's node nodes[k].
  StepInputs OnNodes(const std::vector<int>& nodes) const {
    const int m = static_cast<int>(nodes.size());
    StepInputs w{step, Eigen::VectorXd(m), std::vector<char>(m), Eigen::MatrixX2d(m, 2),
                 shift_increment};
    w.step.gap_mm.resize(m);
    w.step.friction_coefficient.resize(m);
    for (int k = 0; k < m; ++k) {
      const int g = nodes[k];
      w.step.gap_mm[k] = step.gap_mm[g], w.step.friction_coefficient[k] = step.friction_coefficient[g];
      w.h[k] = h[g], w.candidate[k] = candidate[g], w.u_t_prev.row(k) = u_t_prev.row(g);
    }
    return w;
  }
};

struct CouplingOutcome {
  bool converged = false;
  bool gross_sliding = false;
  // The grid's normal displacement under the returned tractions (mm).
  Eigen::VectorXd u_normal_mm;
};

// Alternates the normal and tangential sub-problems on p and q (in place) until the tractions
// stop changing (at once without coupling); adds the iterations to `summary` and sets its
// residuals.
CouplingOutcome AlternateSubProblems(const ComplianceOperator& c,
                                     const StepInputs& in,
                                     const ContactSolverOptions& options,
                                     Eigen::VectorXd& p,
                                     Eigen::MatrixX2d& q,
                                     ContactSummary& summary) {
  const ContactStep& step = in.step;
  const bool coupled = options.coupling == Coupling::kFull;
  CouplingOutcome outcome;
  Eigen::MatrixX2d b(p.size(), 2);
  double lipschitz = 0.0;
  int pass = 1;
  for (; pass <= options.max_coupling_iterations; ++pass) {
    const Eigen::VectorXd p_before = p;
    const Eigen::MatrixX2d q_before = q;
    // The coupling enters each sub-problem as a fixed displacement from the other's tractions.
    Eigen::VectorXd h_eff = in.h;
    if (coupled) h_eff += c.Apply(Components::kNormal, Components::kTangential, q);
    NormalProblem normal_pass(c, h_eff, in.candidate, step, options);
    const SubSolve ns = normal_pass.Solve(p);
    summary.normal_iterations += ns.iterations;
    summary.normal_residual = ns.residual;

    const Eigen::VectorXd bound = step.friction_coefficient.cwiseProduct(p);
    b = -in.u_t_prev;
    b.rowwise() -= in.shift_increment.transpose();
    if (coupled) b += c.Apply(Components::kTangential, Components::kNormal, p);
    TangentialProblem tangential(c, bound, b, step, options);
    SubSolve ts;
    outcome.gross_sliding = tangential.GrossSliding(q);
    if (!outcome.gross_sliding) ts = tangential.Solve(q, lipschitz);
    summary.tangential_iterations += ts.iterations;
    summary.tangential_residual = ts.residual;

    summary.coupling_change = RelativeL1Change(p, p_before) + RelativeL1Change(q, q_before);
    outcome.converged = ns.converged && (outcome.gross_sliding || ts.converged);
    if (!outcome.converged) {  // alternating further cannot help a sub-problem that is not solved
      summary.message =
          !ns.converged ? "normal problem: iteration limit" : "tangential problem: iteration limit";
      break;
    }
    if (!coupled || summary.coupling_change < options.coupling_tolerance) break;
  }
  if (outcome.converged && pass > options.max_coupling_iterations) {
    pass = options.max_coupling_iterations;
    outcome.converged = false;
    summary.message = "normal-tangential coupling: iteration limit";
  }
  summary.coupling_iterations += pass;
  return outcome;
}

// The normal displacement (mm) the tractions p and q make on c's grid.
Eigen::VectorXd CalcNormalDisplacement(const ComplianceOperator& c,
                                       const Eigen::VectorXd& p,
                                       const Eigen::MatrixX2d& q,
                                       bool coupled) {
  Eigen::VectorXd u_normal = c.Apply(Components::kNormal, Components::kNormal, p);
  if (coupled) u_normal += c.Apply(Components::kNormal, Components::kTangential, q);
  return u_normal;
}

// A block of grid nodes: columns [i0, i1), rows [j0, j1).
struct NodeBox {
  int i0 = 0, j0 = 0, i1 = 0, j1 = 0;

  int nx() const { return i1 - i0; }
  int ny() const { return j1 - j0; }
  bool empty() const { return i1 <= i0 || j1 <= j0; }
  bool Contains(int i, int j) const { return i >= i0 && i < i1 && j >= j0 && j < j1; }
  void Add(int i, int j) {
    if (empty()) {
      *this = {i, j, i + 1, j + 1};
    } else {
      i0 = std::min(i0, i), j0 = std::min(j0, j), i1 = std::max(i1, i + 1), j1 = std::max(j1, j + 1);
    }
  }
  void Add(const NodeBox& other) {
    if (other.empty()) return;
    Add(other.i0, other.j0);
    Add(other.i1 - 1, other.j1 - 1);
  }
};

// The box widened on every side by a quarter of its larger side (at least 3 nodes) and to a
// multiple of 4 nodes along each axis (few window sizes, whose compliances are reused), within
// the grid.
NodeBox Padded(NodeBox box, const SurfaceGrid& grid) {
  const int margin = std::max(3, std::max(box.nx(), box.ny()) / 4);
  const auto fit = [margin](int& lo, int& hi, int n) {
    lo = std::max(lo - margin, 0);
    hi = std::min(hi + margin, n);
    const int size = std::min(n, std::max(3, (hi - lo + 3) / 4 * 4));
    hi += size - (hi - lo);
    if (hi > n) lo -= hi - n, hi = n;
  };
  fit(box.i0, box.i1, grid.nx);
  fit(box.j0, box.j1, grid.ny);
  return box;
}

// Where the contact can be: the nodes in contact before and those the indenter overlaps (under
// force control the approach is unknown: the nearest node); empty if none.
NodeBox LikelyContact(const SurfaceGrid& grid,
                      const ContactStep& step,
                      const ContactState& previous,
                      const Eigen::VectorXd& h,
                      const std::vector<char>& candidate) {
  double reach = step.approach_mm;
  if (step.normal_control == NormalControl::kForce) {
    reach = std::numeric_limits<double>::infinity();
    for (int i = 0; i < h.size(); ++i) {
      if (candidate[i]) reach = std::min(reach, h[i]);
    }
  }
  NodeBox box;
  for (int i = 0; i < h.size(); ++i) {
    if (candidate[i] && (previous.pressure_mpa[i] > 0.0 || h[i] <= reach)) box.Add(i % grid.nx, i / grid.nx);
  }
  return box;
}

// A window's solution is the grid's if no contact node lies on the window's border (other than
// the grid's own) and no node outside it penetrates; returns the nodes that break this. Checking
// for penetration (once the border is clear) sets `u_normal` to the grid's normal displacement
// under the tractions, which the state of an accepted window reuses.
NodeBox NodesOutsideTheWindow(const ComplianceOperator& c,
                              const StepInputs& in,
                              const NodeBox& box,
                              const Eigen::VectorXd& p,
                              const Eigen::MatrixX2d& q,
                              bool coupled,
                              Eigen::VectorXd& u_normal) {
  const SurfaceGrid& grid = c.grid();
  NodeBox outside;
  for (int j = box.j0; j < box.j1; ++j) {
    for (int i = box.i0; i < box.i1; ++i) {
      const bool border = (i == box.i0 && i > 0) || (i == box.i1 - 1 && i < grid.nx - 1) ||
                          (j == box.j0 && j > 0) || (j == box.j1 - 1 && j < grid.ny - 1);
      if (border && p[j * grid.nx + i] > 0.0) outside.Add(i, j);
    }
  }
  if (!outside.empty()) return outside;
  u_normal = CalcNormalDisplacement(c, p, q, coupled);
  const Eigen::VectorXd& h = in.h;
  const double approach = CalcApproach(in.step, p, h, in.candidate, u_normal);
  // Penetration beyond the solver's own rounding (its gaps in contact are ~1e-7 of u).
  const double tolerance = 1e-6 * u_normal.cwiseAbs().maxCoeff();
  for (int k = 0; k < h.size(); ++k) {
    const int i = k % grid.nx, j = k / grid.nx;
    if (in.candidate[k] && !box.Contains(i, j) && h[k] + u_normal[k] - approach < -tolerance) {
      outside.Add(i, j);
    }
  }
  return outside;
}

// AlternateSubProblems on windows of the grid around the contact (`window` gives a window's
// compliance, null to use the whole grid), grown until the window's solution is the grid's.
// p and q are the grid's, in and out; the summary's iterations add up over the windows tried.
CouplingOutcome AlternateOnWindows(
    const ComplianceOperator& c,
    const std::function<std::shared_ptr<const ComplianceOperator>(int, int)>& window,
    const StepInputs& in,
    const ContactSolverOptions& options,
    const ContactState& previous,
    Eigen::VectorXd& p,
    Eigen::MatrixX2d& q,
    ContactSummary& summary) {
  const SurfaceGrid& grid = c.grid();
  const bool coupled = options.coupling == Coupling::kFull;
  const NodeBox likely = LikelyContact(grid, in.step, previous, in.h, in.candidate);
  NodeBox box = Padded(likely, grid);
  for (;;) {
    ++summary.window_attempts;
    // A window of most of the grid saves little.
    const bool whole = likely.empty() || box.nx() * box.ny() > 0.6 * grid.num_nodes();
    const std::shared_ptr<const ComplianceOperator> w = whole ? nullptr : window(box.nx(), box.ny());
    if (!w) {
      summary.window_nx = grid.nx, summary.window_ny = grid.ny;
      CouplingOutcome outcome = AlternateSubProblems(c, in, options, p, q, summary);
      outcome.u_normal_mm = CalcNormalDisplacement(c, p, q, coupled);
      return outcome;
    }
    summary.window_nx = box.nx(), summary.window_ny = box.ny();
    std::vector<int> nodes;  // window node k is grid node nodes[k]
    for (int j = box.j0; j < box.j1; ++j) {
      for (int i = box.i0; i < box.i1; ++i) nodes.push_back(j * grid.nx + i);
    }
    const int m = static_cast<int>(nodes.size());
    Eigen::VectorXd p_w(m);
    Eigen::MatrixX2d q_w(m, 2);
    for (int k = 0; k < m; ++k) p_w[k] = p[nodes[k]], q_w.row(k) = q.row(nodes[k]);
    CouplingOutcome outcome =
        AlternateSubProblems(*w, in.OnNodes(nodes), options, p_w, q_w, summary);
    p.setZero();
    q.setZero();
    for (int k = 0; k < m; ++k) p[nodes[k]] = p_w[k], q.row(nodes[k]) = q_w.row(k);
    if (!outcome.converged) {
      outcome.u_normal_mm = CalcNormalDisplacement(c, p, q, coupled);
      return outcome;
    }
    const NodeBox outside =
        NodesOutsideTheWindow(c, in, box, p, q, coupled, outcome.u_normal_mm);
    if (outside.empty()) return outcome;
    box.Add(outside);
    box = Padded(box, grid);
  }
}

// The state the tractions imply: tractions, displacements, approach and resultant forces (the
// shift and slip come later, from the stick nodes). `u_normal` is their normal displacement.
void SetImpliedState(const ComplianceOperator& c,
                     const StepInputs& in,
                     const Eigen::VectorXd& p,
                     const Eigen::MatrixX2d& q,
                     const Eigen::VectorXd& u_normal,
                     bool coupled,
                     ContactState& state) {
  const double area = c.grid().cell_area_mm2();
  state.pressure_mpa = p;
  state.traction_mpa = q;
  state.displacement_mm.resize(p.size(), 3);
  state.displacement_mm.leftCols<2>() =
      c.Apply(Components::kTangential, Components::kTangential, q);
  if (coupled) {
    state.displacement_mm.leftCols<2>() += c.Apply(Components::kTangential, Components::kNormal, p);
  }
  state.displacement_mm.col(2) = u_normal;
  state.approach_mm = CalcApproach(in.step, p, in.h, in.candidate, u_normal);
  state.normal_force_n = p.sum() * area;
  state.tangential_force_n = q.colwise().sum().transpose() * area;
}

// Labels each node separated, stick or slip (on the friction cone), counts them into
// `summary` and returns the sum of the stick nodes' elastic increments.
Eigen::Vector2d ClassifyNodes(const SurfaceGrid& grid,
                              const ContactStep& step,
                              const Eigen::VectorXd& p,
                              const Eigen::MatrixX2d& q,
                              const Eigen::MatrixX2d& elastic_increment,
                              std::vector<NodeState>& node_state,
                              ContactSummary& summary) {
  const int n = static_cast<int>(p.size());
  node_state.assign(n, NodeState::kSeparated);
  Eigen::Vector2d stick_sum = Eigen::Vector2d::Zero();
  for (int i = 0; i < n; ++i) {
    if (!(p[i] > 0.0)) continue;
    ++summary.num_contact;
    const bool slip = q.row(i).norm() >= (1.0 - kOnCone) * step.friction_coefficient[i] * p[i];
    node_state[i] = slip ? NodeState::kSlip : NodeState::kStick;
    if (slip) {
      ++summary.num_slip;
    } else {
      ++summary.num_stick;
      stick_sum += elastic_increment.row(i).transpose();
    }
    if (grid.is_edge_node(i)) summary.contact_at_grid_edge = true;
  }
  return stick_sum;
}

// Under force control the shift increment is what the stick nodes moved (their slip is 0).
// Without stick nodes it is undetermined: the indenter slides off under a force (which sets
// `gross_sliding` and returns NaN), and with no force nothing drives it, so it stays.
Eigen::Vector2d CalcShiftIncrement(const ContactStep& step,
                                   const Eigen::Vector2d& shift_increment,
                                   const Eigen::Vector2d& stick_sum,
                                   int num_stick,
                                   bool& gross_sliding) {
  Eigen::Vector2d increment = shift_increment;
  if (step.tangential_control == TangentialControl::kForce) {
    if (num_stick > 0 && !gross_sliding) {
      increment = stick_sum / num_stick;
    } else if (step.tangential_force_n.norm() > 0.0) {
      gross_sliding = true;
      increment = Eigen::Vector2d::Constant(kNaN);
    }
  }
  return increment;
}

// The indenter's new shift, and each contact node's slip relative to it.
void SetShiftAndSlip(const ContactState& previous,
                     const Eigen::Vector2d& increment,
                     const Eigen::MatrixX2d& elastic_increment,
                     ContactResult& result) {
  ContactState& state = result.state;
  const int n = static_cast<int>(result.node_state.size());
  state.shift_mm = previous.shift_mm + increment;
  state.slip_mm = Eigen::MatrixX2d::Zero(n, 2);
  for (int i = 0; i < n; ++i) {
    if (result.node_state[i] != NodeState::kSeparated) {
      state.slip_mm.row(i) = elastic_increment.row(i) - increment.transpose();
    }
  }
}

// How well the returned state meets the contact conditions (gap, complementarity,
// penetration, friction cone, stick and slip direction), into the summary.
void MeasureContactConditions(const ContactStep& step,
                              const Eigen::VectorXd& h,
                              const std::vector<char>& candidate,
                              ContactResult& result) {
  const ContactState& state = result.state;
  const Eigen::VectorXd& p = state.pressure_mpa;
  const Eigen::MatrixX2d& q = state.traction_mpa;
  ContactSummary& summary = result.summary;
  const int n = static_cast<int>(p.size());
  double max_slip = 0.0;
  for (int i = 0; i < n; ++i) {
    if (result.node_state[i] == NodeState::kSlip)
      max_slip = std::max(max_slip, state.slip_mm.row(i).norm());
  }
  summary.min_pressure_mpa = n > 0 ? p.minCoeff() : 0.0;
  for (int i = 0; i < n; ++i) {
    if (!candidate[i]) continue;
    const double g = h[i] + state.displacement_mm(i, 2) - state.approach_mm;
    if (p[i] > 0.0) {
      summary.max_gap_in_contact_mm = std::max(summary.max_gap_in_contact_mm, std::abs(g));
      summary.max_complementarity_mpa_mm =
          std::max(summary.max_complementarity_mpa_mm, p[i] * std::abs(g));
    }
    summary.max_penetration_mm = std::max(summary.max_penetration_mm, -g);
    summary.max_cone_violation_mpa = std::max(
        summary.max_cone_violation_mpa, q.row(i).norm() - step.friction_coefficient[i] * p[i]);
    if (result.node_state[i] == NodeState::kStick) {
      summary.max_stick_slip_mm = std::max(summary.max_stick_slip_mm, state.slip_mm.row(i).norm());
    } else if (result.node_state[i] == NodeState::kSlip && std::isfinite(max_slip)) {
      const Eigen::Vector2d slip = state.slip_mm.row(i).transpose();
      const Eigen::Vector2d qi = q.row(i).transpose();
      if (slip.norm() > 1e-3 * max_slip && qi.norm() > 0.0) {
        const double cosine = std::clamp(-slip.dot(qi) / (slip.norm() * qi.norm()), -1.0, 1.0);
        summary.max_slip_direction_error_rad =
            std::max(summary.max_slip_direction_error_rad, std::acos(cosine));
      }
    }
  }
}

}  // namespace

void ContactSolverOptions::Validate() const {
  const auto positive = [](const char* name, int value) {
    if (value < 1)
      throw Error(fmt::format("ContactSolverOptions.{} must be >= 1, got {}", name, value));
  };
  positive("max_coupling_iterations", max_coupling_iterations);
  positive("max_normal_iterations", max_normal_iterations);
  positive("max_tangential_iterations", max_tangential_iterations);
  const auto fraction = [](const char* name, double value) {
    if (!(value > 0.0 && value < 1.0)) {
      throw Error(fmt::format("ContactSolverOptions.{} must be in (0, 1), got {}", name, value));
    }
  };
  fraction("normal_tolerance", normal_tolerance);
  fraction("tangential_tolerance", tangential_tolerance);
  fraction("coupling_tolerance", coupling_tolerance);
}

void ContactStep::Validate(int num_nodes) const {
  if (gap_mm.size() != num_nodes || friction_coefficient.size() != num_nodes) {
    throw Error(
        fmt::format("ContactStep: gap_mm and friction_coefficient need {} values (one a "
                    "node), got {} and {}",
                    num_nodes,
                    gap_mm.size(),
                    friction_coefficient.size()));
  }
  for (int i = 0; i < num_nodes; ++i) {
    if (std::isnan(gap_mm[i]) || gap_mm[i] == -std::numeric_limits<double>::infinity()) {
      throw Error(fmt::format("ContactStep.gap_mm[{}] is {}", i, gap_mm[i]));
    }
    const double mu = friction_coefficient[i];
    if (!(mu >= 0.0 && std::isfinite(mu))) {
      throw Error(fmt::format("ContactStep.friction_coefficient[{}] must be >= 0, got {}", i, mu));
    }
  }
  if (!(normal_force_n >= 0.0 && std::isfinite(normal_force_n))) {
    throw Error(fmt::format("ContactStep.normal_force_n must be >= 0, got {}", normal_force_n));
  }
  if (!std::isfinite(approach_mm) || !tangential_force_n.allFinite() || !shift_mm.allFinite()) {
    throw Error("ContactStep: approach_mm, tangential_force_n and shift_mm must be finite");
  }
}

ContactState ContactState::Unloaded(int num_nodes) {
  ContactState state;
  state.pressure_mpa = Eigen::VectorXd::Zero(num_nodes);
  state.traction_mpa = Eigen::MatrixX2d::Zero(num_nodes, 2);
  state.displacement_mm = Eigen::MatrixX3d::Zero(num_nodes, 3);
  state.slip_mm = Eigen::MatrixX2d::Zero(num_nodes, 2);
  return state;
}

std::string ToString(ContactStatus status) {
  switch (status) {
    case ContactStatus::kConverged:
      return "converged";
    case ContactStatus::kGrossSliding:
      return "gross sliding";
    case ContactStatus::kMaxIterations:
      return "iteration limit";
  }
  TAC3D_DEMAND(false);
}

nlohmann::json ToJson(const ContactSummary& s) {
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"coupling_iterations", s.coupling_iterations},
          {"normal_iterations", s.normal_iterations},
          {"tangential_iterations", s.tangential_iterations},
          {"normal_residual", s.normal_residual},
          {"tangential_residual", s.tangential_residual},
          {"coupling_change", s.coupling_change},
          {"max_gap_in_contact_mm", s.max_gap_in_contact_mm},
          {"max_penetration_mm", s.max_penetration_mm},
          {"max_complementarity_mpa_mm", s.max_complementarity_mpa_mm},
          {"min_pressure_mpa", s.min_pressure_mpa},
          {"max_cone_violation_mpa", s.max_cone_violation_mpa},
          {"max_stick_slip_mm", s.max_stick_slip_mm},
          {"max_slip_direction_error_rad", s.max_slip_direction_error_rad},
          {"num_contact", s.num_contact},
          {"num_stick", s.num_stick},
          {"num_slip", s.num_slip},
          {"contact_at_grid_edge", s.contact_at_grid_edge},
          {"window", {s.window_nx, s.window_ny}},
          {"window_attempts", s.window_attempts},
          {"time_s", s.time_s}};
}

struct ContactSolver::WindowCache {
  std::mutex mutex;
  std::map<std::pair<int, int>, std::shared_ptr<const ComplianceOperator>> by_size;
};

ContactSolver::ContactSolver(std::shared_ptr<const ComplianceOperator> compliance,
                             const ContactSolverOptions& options)
    : compliance_(std::move(compliance)),
      options_(options),
      windows_(std::make_shared<WindowCache>()) {
  if (!compliance_) throw Error("ContactSolver: no compliance operator");
  options_.Validate();
}

std::shared_ptr<const ComplianceOperator> ContactSolver::WindowCompliance(int nx, int ny) const {
  if (!options_.windowed) return nullptr;
  const std::lock_guard lock(windows_->mutex);
  // Bounded: a long run meets many contact sizes; a window's compliance is made in milliseconds.
  if (windows_->by_size.size() >= 32) windows_->by_size.clear();
  std::shared_ptr<const ComplianceOperator>& w = windows_->by_size[{nx, ny}];
  if (!w) w = compliance_->Window(nx, ny);
  return w;
}

ContactResult ContactSolver::Solve(const ContactStep& step, const ContactState& previous) const {
  const auto start = std::chrono::steady_clock::now();
  const ComplianceOperator& c = *compliance_;
  const int n = c.grid().num_nodes();
  step.Validate(n);
  RequirePreviousState(previous, n);
  // Infinite gaps become a finite stand-in; those nodes never carry pressure.
  const StepInputs in{
      step,
      step.gap_mm.unaryExpr([](double v) { return std::isfinite(v) ? v : 0.0; }),
      CandidateNodes(step),
      previous.displacement_mm.leftCols<2>(),
      step.tangential_control == TangentialControl::kShift
          ? Eigen::Vector2d(step.shift_mm - previous.shift_mm)
          : Eigen::Vector2d::Zero()};
  const bool coupled = options_.coupling == Coupling::kFull;

  Eigen::VectorXd p = previous.pressure_mpa;
  Eigen::MatrixX2d q = previous.traction_mpa;
  for (int i = 0; i < n; ++i) {
    if (!in.candidate[i]) p[i] = 0.0, q.row(i).setZero();
  }
  ContactResult result;
  ContactSummary& summary = result.summary;
  const CouplingOutcome outcome = AlternateOnWindows(
      c, [this](int nx, int ny) { return WindowCompliance(nx, ny); }, in, options_, previous, p, q,
      summary);
  bool gross_sliding = outcome.gross_sliding;
  SetImpliedState(c, in, p, q, outcome.u_normal_mm, coupled, result.state);
  const Eigen::MatrixX2d elastic_increment =
      result.state.displacement_mm.leftCols<2>() - in.u_t_prev;
  const Eigen::Vector2d stick_sum =
      ClassifyNodes(c.grid(), step, p, q, elastic_increment, result.node_state, summary);
  const Eigen::Vector2d increment =
      CalcShiftIncrement(step, in.shift_increment, stick_sum, summary.num_stick, gross_sliding);
  SetShiftAndSlip(previous, increment, elastic_increment, result);
  MeasureContactConditions(step, in.h, in.candidate, result);

  if (!outcome.converged) {
    summary.status = ContactStatus::kMaxIterations;
  } else if (gross_sliding) {
    summary.status = ContactStatus::kGrossSliding;
    summary.message = "the tangential force reaches the friction capacity";
  }
  summary.time_s = SecondsSince(start);
  return result;
}

}  // namespace tac3d::contact
