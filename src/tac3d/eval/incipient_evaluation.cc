#include "tac3d/eval/incipient_evaluation.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/util/error.h"
#include "tac3d/util/json_number.h"
#include "tac3d/util/percentile.h"

namespace tac3d {
namespace {

constexpr double kNaN = IncipientEvaluation::kNaN;

double Ratio(int part, int whole) { return whole > 0 ? static_cast<double>(part) / whole : kNaN; }

// The figures that follow from the error lists and the counts.
void Finish(IncipientEvaluation& e) {
  e.mu_error_median = Percentile(e.mu_errors, 0.5);
  e.mu_error_p90 = Percentile(e.mu_errors, 0.9);
  e.margin_error_median = Percentile(e.margin_errors, 0.5);
  e.margin_error_p90 = Percentile(e.margin_errors, 0.9);
  e.false_alarm_rate = Ratio(e.false_alarms, e.stick_frames);
  e.coverage = Ratio(e.covered_frames, e.sigma_frames);
}

// The lead: walking back from the last frame before gross slip while the estimate is within.
void MeasureLead(const std::vector<IncipientFrame>& frames, double within_mu, IncipientEvaluation& e) {
  if (!std::isfinite(e.gross_slip_s)) return;
  for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
    if (it->truth.t_s >= e.gross_slip_s) continue;
    const double error = std::abs(it->estimate.friction - it->truth.mu);
    if (!it->truth.in_contact() || !(error <= within_mu)) break;
    e.within_since_s = it->truth.t_s;
  }
  e.lead_s = std::isfinite(e.within_since_s) ? e.gross_slip_s - e.within_since_s : 0.0;
  const double ramp_s = e.gross_slip_s - e.ramp_start_s;
  e.lead_ramp_fraction = ramp_s > 0.0 ? e.lead_s / ramp_s : kNaN;
}

}  // namespace

double IncipientTruth::stick_fraction() const {
  return contact_nodes > 0 ? static_cast<double>(stick_nodes) / contact_nodes : kNaN;
}

IncipientTruth IncipientTruthOf(const TwinStep& step, double mu, double cell_area_mm2) {
  if (!(mu > 0.0)) throw Error(fmt::format("incipient truth: mu must be > 0, got {}", mu));
  if (!(cell_area_mm2 > 0.0)) {
    throw Error(fmt::format("incipient truth: cell_area_mm2 must be > 0, got {}", cell_area_mm2));
  }
  if (step.surface.states.empty()) {
    throw Error(fmt::format("incipient truth: step {} has no surface tractions (read it with its surface)",
                            step.index));
  }
  IncipientTruth t;
  t.t_s = step.t_s;
  t.mu = mu;
  t.normal_force_n = -step.total_force_n.z();
  t.tangential_force_n = step.total_force_n.head<2>().norm();
  for (const ContactState s : step.surface.states) {
    t.contact_nodes += s != ContactState::kSeparated;
    t.stick_nodes += s == ContactState::kStick;
  }
  t.stick_area_mm2 = t.stick_nodes * cell_area_mm2;
  if (t.in_contact() && t.normal_force_n > 0.0) t.load_ratio = t.tangential_force_n / (mu * t.normal_force_n);
  return t;
}

void IncipientEvaluationOptions::Validate() const {
  const auto require = [](bool ok, const char* field, const char* bound, double value) {
    if (!ok) throw Error(fmt::format("incipient evaluation: {} must be {}, got {}", field, bound, value));
  };
  require(window_from >= 0.0 && window_from < window_to, "window_from", "in [0, window_to)", window_from);
  require(window_to <= 1.0, "window_to", "<= 1", window_to);
  require(within_mu > 0.0, "within_mu", "> 0", within_mu);
  require(stick_load_ratio > 0.0, "stick_load_ratio", "> 0", stick_load_ratio);
  require(alarm_margin > 0.0, "alarm_margin", "> 0", alarm_margin);
  require(coverage_sigmas > 0.0, "coverage_sigmas", "> 0", coverage_sigmas);
  require(target_coverage > 0.0 && target_coverage <= 1.0, "target_coverage", "in (0, 1]", target_coverage);
}

IncipientEvaluation EvaluateIncipient(const std::string& scene,
                                      const std::vector<IncipientFrame>& frames,
                                      double ramp_start_s,
                                      bool slow_ramp,
                                      const IncipientEvaluationOptions& options) {
  options.Validate();
  IncipientEvaluation e;
  e.scene = scene;
  e.slow_ramp = slow_ramp;
  e.slow_ramps = slow_ramp ? 1 : 0;
  e.ramp_start_s = ramp_start_s;
  e.frames = static_cast<int>(frames.size());
  for (const IncipientFrame& f : frames) {
    if (f.truth.t_s >= ramp_start_s && f.truth.gross_slip()) {
      e.gross_slip_s = f.truth.t_s;
      break;
    }
  }
  for (const IncipientFrame& f : frames) {
    const IncipientTruth& t = f.truth;
    if (!t.in_contact() || !std::isfinite(t.load_ratio)) continue;
    ++e.contact_frames;
    e.max_load_ratio = std::isfinite(e.max_load_ratio) ? std::max(e.max_load_ratio, t.load_ratio) : t.load_ratio;
    if (!std::isfinite(e.ramp_normal_force_n) && t.t_s >= ramp_start_s) e.ramp_normal_force_n = t.normal_force_n;
    const double mu_error = std::abs(f.estimate.friction - t.mu);
    const bool before_gross = !(t.t_s >= e.gross_slip_s);
    if (before_gross && t.load_ratio >= options.window_from && t.load_ratio <= options.window_to) {
      ++e.window_frames;
      if (std::isfinite(mu_error)) {
        ++e.window_estimated_frames;
        e.mu_errors.push_back(mu_error);
      }
      const double margin_error = std::abs(f.estimate.margin - (1.0 - t.load_ratio));
      if (std::isfinite(margin_error)) e.margin_errors.push_back(margin_error);
    }
    if (before_gross && t.load_ratio < options.stick_load_ratio) {
      ++e.stick_frames;
      e.false_alarms += f.estimate.margin < options.alarm_margin;
    }
    if (std::isfinite(mu_error) && std::isfinite(f.estimate.friction_sigma)) {
      ++e.sigma_frames;
      e.covered_frames += mu_error <= options.coverage_sigmas * f.estimate.friction_sigma;
    }
  }
  MeasureLead(frames, options.within_mu, e);
  Finish(e);
  return e;
}

IncipientEvaluation PoolIncipientEvaluations(const std::vector<IncipientEvaluation>& scenes) {
  IncipientEvaluation p;
  p.scene = "overall";
  for (const IncipientEvaluation& e : scenes) {
    p.frames += e.frames;
    p.contact_frames += e.contact_frames;
    p.window_frames += e.window_frames;
    p.window_estimated_frames += e.window_estimated_frames;
    p.mu_errors.insert(p.mu_errors.end(), e.mu_errors.begin(), e.mu_errors.end());
    p.margin_errors.insert(p.margin_errors.end(), e.margin_errors.begin(), e.margin_errors.end());
    p.stick_frames += e.stick_frames;
    p.false_alarms += e.false_alarms;
    p.sigma_frames += e.sigma_frames;
    p.covered_frames += e.covered_frames;
    if (std::isfinite(e.max_load_ratio)) p.max_load_ratio = std::isfinite(p.max_load_ratio) ? std::max(p.max_load_ratio, e.max_load_ratio) : e.max_load_ratio;
    if (!e.slow_ramp) continue;
    // The least lead over the slow ramps; one without a lead (no gross slip) makes it NaN.
    p.lead_s = p.slow_ramps == 0 ? e.lead_s : std::min(p.lead_s, e.lead_s);
    p.lead_ramp_fraction = p.slow_ramps == 0 ? e.lead_ramp_fraction : std::min(p.lead_ramp_fraction, e.lead_ramp_fraction);
    if (std::isnan(e.lead_s)) p.lead_s = kNaN;
    if (std::isnan(e.lead_ramp_fraction)) p.lead_ramp_fraction = kNaN;
    ++p.slow_ramps;
  }
  p.slow_ramp = p.slow_ramps > 0;
  Finish(p);
  return p;
}

std::vector<EvalCheck> IncipientChecks(const IncipientEvaluation& e, const IncipientEvaluationOptions& o) {
  std::vector<EvalCheck> checks = {
      EvalCheck::AtMost("mu_error_median", e.mu_error_median, o.target_mu_error_median),
      EvalCheck::AtMost("mu_error_p90", e.mu_error_p90, o.target_mu_error_p90)};
  checks.push_back(e.slow_ramps > 0
                       ? EvalCheck::AtLeast("lead_ms_slow_ramps", 1e3 * e.lead_s, 1e3 * o.target_lead_s, "ms")
                       : EvalCheck::NotApplicable("lead_ms_slow_ramps", 1e3 * o.target_lead_s,
                                                  EvalCheck::Bound::kAtLeast, "ms"));
  checks.push_back(EvalCheck::AtMost("false_alarm_rate", e.false_alarm_rate, o.target_false_alarm_rate));
  checks.push_back(EvalCheck::AtLeast("coverage", e.coverage, o.target_coverage));
  return checks;
}

nlohmann::json ToJson(const IncipientEvaluation& e, const IncipientEvaluationOptions& options) {
  nlohmann::json j = {{"scene", e.scene},
                      {"frames", e.frames},
                      {"contact_frames", e.contact_frames},
                      {"window_frames", e.window_frames},
                      {"window_estimated_frames", e.window_estimated_frames},
                      {"mu_error_median", FiniteOrNull(e.mu_error_median)},
                      {"mu_error_p90", FiniteOrNull(e.mu_error_p90)},
                      {"margin_frames", e.margin_errors.size()},
                      {"margin_error_median", FiniteOrNull(e.margin_error_median)},
                      {"margin_error_p90", FiniteOrNull(e.margin_error_p90)},
                      {"lead_ms", FiniteOrNull(1e3 * e.lead_s)},
                      {"lead_ramp_fraction", FiniteOrNull(e.lead_ramp_fraction)},
                      {"stick_frames", e.stick_frames},
                      {"false_alarms", e.false_alarms},
                      {"false_alarm_rate", FiniteOrNull(e.false_alarm_rate)},
                      {"sigma_frames", e.sigma_frames},
                      {"covered_frames", e.covered_frames},
                      {"coverage", FiniteOrNull(e.coverage)},
                      {"max_load_ratio", FiniteOrNull(e.max_load_ratio)}};
  if (e.scene == "overall") {
    const std::vector<EvalCheck> checks = IncipientChecks(e, options);
    j["slow_ramps"] = e.slow_ramps;
    j["checks"] = ToJson(checks);
    j["all_pass"] = AllPass(checks);
    return j;
  }
  j["slow_ramp"] = e.slow_ramp;
  j["ramp_start_s"] = FiniteOrNull(e.ramp_start_s);
  j["ramp_normal_force_n"] = FiniteOrNull(e.ramp_normal_force_n);
  j["gross_slip_s"] = FiniteOrNull(e.gross_slip_s);
  j["within_since_s"] = FiniteOrNull(e.within_since_s);
  return j;
}

std::string IncipientEvaluation::BriefReport() const {
  const auto number = [](double v, const char* format) {
    return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : std::string("n/a");
  };
  return fmt::format(
      "{}: mu error median {} p90 {} ({} of {} window frames estimated), margin error median {} p90 {}, "
      "lead {} ms ({} of the ramp), false alarms {}/{}, coverage {} ({} frames), max Q/(mu P) {}",
      scene, number(mu_error_median, "{:.3f}"), number(mu_error_p90, "{:.3f}"), window_estimated_frames,
      window_frames, number(margin_error_median, "{:.3f}"), number(margin_error_p90, "{:.3f}"),
      number(1e3 * lead_s, "{:.0f}"), number(lead_ramp_fraction, "{:.2f}"), false_alarms, stick_frames,
      number(coverage, "{:.3f}"), sigma_frames, number(max_load_ratio, "{:.2f}"));
}

}  // namespace tac3d
