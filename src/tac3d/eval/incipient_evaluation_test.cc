#include "tac3d/eval/incipient_evaluation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

constexpr double kRampMu = 0.6;


// A hand-built scene at 100 frames a second: no contact for t < 0.1 s, pressed (load ratio 0)
// until the ramp starts at 0.2 s, then the load ratio rises by 0.01 a frame and the contact
// slips as a whole from 1.2 s (ratio 1) on. The estimate: mu + `bias` from t >= estimate_from_s,
// the margin 1 - ratio + 0.02, sigma 0.05.
std::vector<IncipientFrame> IncipientRamp(double bias, double estimate_from_s) {
  std::vector<IncipientFrame> frames;
  for (int k = 0; k < 140; ++k) {
    IncipientFrame f;
    IncipientTruth& t = f.truth;
    t.t_s = k / 100.0;
    t.mu = kRampMu;
    if (k >= 10) {
      const double ratio = std::min(1.0, std::max(0.0, (k - 20) / 100.0));
      t.contact_nodes = 100;
      t.stick_nodes = ratio >= 1.0 ? 0 : static_cast<int>(100 * (1.0 - ratio));
      t.normal_force_n = 2.0;
      t.tangential_force_n = ratio * kRampMu * 2.0;
      t.load_ratio = ratio;
      f.estimate.margin = 1.0 - ratio + 0.02;
      if (t.t_s >= estimate_from_s - 1e-9) {
        f.estimate.friction = kRampMu + bias;
        f.estimate.friction_sigma = 0.05;
      }
    }
    frames.push_back(f);
  }
  return frames;
}

TEST(EvaluateIncipient, MeasuresTheErrorsTheLeadAndTheCoverage) {
  const IncipientEvaluation e = EvaluateIncipient("ramp", IncipientRamp(0.08, 0.6), 0.2, true);
  EXPECT_EQ(e.frames, 140);
  EXPECT_EQ(e.contact_frames, 130);
  EXPECT_NEAR(e.gross_slip_s, 1.2, 1e-12);
  // Window: ratio 0.50 .. 0.90, t = 0.70 .. 1.10 s, 41 frames, all estimated (from 0.6 s).
  EXPECT_EQ(e.window_frames, 41);
  EXPECT_EQ(e.window_estimated_frames, 41);
  EXPECT_NEAR(e.mu_error_median, 0.08, 1e-12);
  EXPECT_NEAR(e.mu_error_p90, 0.08, 1e-12);
  EXPECT_NEAR(e.margin_error_median, 0.02, 1e-12);
  // Within 0.1 from 0.6 s until gross slip at 1.2 s: 600 ms, 0.6 of the ramp's 1 s.
  EXPECT_NEAR(e.within_since_s, 0.6, 1e-12);
  EXPECT_NEAR(e.lead_s, 0.6, 1e-12);
  EXPECT_NEAR(e.lead_ramp_fraction, 0.6, 1e-12);
  // Pure stick: ratio < 0.3 in contact, t = 0.10 .. 0.49 s: 40 frames, margins >= 0.73.
  EXPECT_EQ(e.stick_frames, 40);
  EXPECT_EQ(e.false_alarms, 0);
  EXPECT_DOUBLE_EQ(e.false_alarm_rate, 0.0);
  // Every estimated frame is 0.08 off with sigma 0.05: within 2 sigma (0.1).
  EXPECT_EQ(e.sigma_frames, 80);
  EXPECT_DOUBLE_EQ(e.coverage, 1.0);
  EXPECT_DOUBLE_EQ(e.max_load_ratio, 1.0);
  EXPECT_DOUBLE_EQ(e.ramp_normal_force_n, 2.0);

  // Off by 0.12: never within; outside 2 sigma; the lead is 0.
  const IncipientEvaluation off = EvaluateIncipient("ramp", IncipientRamp(0.12, 0.6), 0.2, true);
  EXPECT_TRUE(std::isnan(off.within_since_s));
  EXPECT_DOUBLE_EQ(off.lead_s, 0.0);
  EXPECT_DOUBLE_EQ(off.coverage, 0.0);
  EXPECT_FALSE(IncipientChecks(off)[4].pass);  // coverage 0 < 0.9
  EXPECT_TRUE(IncipientChecks(e)[4].pass);
}

TEST(EvaluateIncipient, NoEstimateIsNotMeasuredAndAlarmsCount) {
  // No mu estimate at all (today's estimator before gross slip): nothing to judge mu on.
  std::vector<IncipientFrame> frames = IncipientRamp(0.0, 99.0);
  for (IncipientFrame& f : frames) {
    if (f.truth.load_ratio < 0.1) f.estimate.margin = 0.4;  // alarms in the first 10 stick frames
  }
  const IncipientEvaluation e = EvaluateIncipient("blind", frames, 0.2, true);
  EXPECT_EQ(e.window_frames, 41);
  EXPECT_EQ(e.window_estimated_frames, 0);
  EXPECT_TRUE(std::isnan(e.mu_error_median));
  EXPECT_DOUBLE_EQ(e.lead_s, 0.0);
  EXPECT_EQ(e.sigma_frames, 0);
  EXPECT_TRUE(std::isnan(e.coverage));
  // Ratio < 0.1: t = 0.10 .. 0.29 s, 20 of the 40 stick frames.
  EXPECT_EQ(e.false_alarms, 20);
  EXPECT_DOUBLE_EQ(e.false_alarm_rate, 0.5);
  const std::vector<EvalCheck> checks = IncipientChecks(PoolIncipientEvaluations({e}));
  ASSERT_EQ(checks.size(), 5u);
  for (const EvalCheck& c : checks) EXPECT_FALSE(c.pass) << c.name;
}

TEST(EvaluateIncipient, GrossSlipAtTouchDownIsNotTheRamps) {
  std::vector<IncipientFrame> frames = IncipientRamp(0.0, 0.0);
  frames[10].truth.stick_nodes = 0;  // the first contact frame slips as a whole
  const IncipientEvaluation e = EvaluateIncipient("touch", frames, 0.2, false);
  EXPECT_NEAR(e.gross_slip_s, 1.2, 1e-12);
}

TEST(PoolIncipientEvaluations, PoolsFramesAndTakesTheLeastSlowLead) {
  const IncipientEvaluation slow = EvaluateIncipient("slow", IncipientRamp(0.03, 0.6), 0.2, true);
  const IncipientEvaluation slower = EvaluateIncipient("slower", IncipientRamp(0.03, 0.85), 0.2, true);
  const IncipientEvaluation fast = EvaluateIncipient("fast", IncipientRamp(0.03, 1.15), 0.2, false);
  const IncipientEvaluation p = PoolIncipientEvaluations({slow, slower, fast});
  EXPECT_EQ(p.scene, "overall");
  EXPECT_EQ(p.slow_ramps, 2);
  EXPECT_EQ(p.window_frames, 3 * 41);
  EXPECT_EQ(p.window_estimated_frames, 41 + 26 + 0);  // from 0.85 s: t = 0.85 .. 1.10 s
  EXPECT_EQ(p.mu_errors.size(), 67u);
  EXPECT_NEAR(p.mu_error_median, 0.03, 1e-12);
  EXPECT_NEAR(p.lead_s, 0.35, 1e-12);  // the slower one's; the fast ramp's 50 ms does not count
  const std::vector<EvalCheck> checks = IncipientChecks(p);
  for (const EvalCheck& c : checks) EXPECT_TRUE(c.pass) << c.name << " " << c.value;
  const nlohmann::json j = ToJson(p);
  EXPECT_TRUE(j.at("all_pass").get<bool>());
  EXPECT_EQ(j.at("checks").size(), 5u);
  EXPECT_NEAR(j.at("lead_ms").get<double>(), 350.0, 1e-9);
  // A slow ramp without gross slip has no lead: the check fails.
  std::vector<IncipientFrame> stuck = IncipientRamp(0.03, 0.6);
  stuck.resize(100);
  const IncipientEvaluation none = EvaluateIncipient("stuck", stuck, 0.2, true);
  EXPECT_TRUE(std::isnan(none.lead_s));
  EXPECT_TRUE(ToJson(none).at("lead_ms").is_null());
  EXPECT_FALSE(IncipientChecks(PoolIncipientEvaluations({slow, none}))[2].pass);
}

TEST(IncipientTruthOf, ReadsTheResultantAndTheStickNodes) {
  TwinStep step;
  step.index = 7;
  step.t_s = 0.5;
  step.total_force_n = {0.3, -0.4, -2.0};
  step.surface.states = {ContactState::kSeparated, ContactState::kStick, ContactState::kStick,
                         ContactState::kSlip};
  step.surface.positions_mm.resize(4);
  step.surface.tractions_mpa.resize(4);
  const IncipientTruth t = IncipientTruthOf(step, 0.5, 0.25);
  EXPECT_DOUBLE_EQ(t.normal_force_n, 2.0);
  EXPECT_DOUBLE_EQ(t.tangential_force_n, 0.5);
  EXPECT_DOUBLE_EQ(t.load_ratio, 0.5);
  EXPECT_EQ(t.contact_nodes, 3);
  EXPECT_EQ(t.stick_nodes, 2);
  EXPECT_DOUBLE_EQ(t.stick_area_mm2, 0.5);
  EXPECT_DOUBLE_EQ(t.stick_fraction(), 2.0 / 3.0);
  EXPECT_FALSE(t.gross_slip());
  step.surface.states = {ContactState::kSeparated};
  EXPECT_TRUE(std::isnan(IncipientTruthOf(step, 0.5, 0.25).load_ratio));
}

TEST(IncipientTruthOf, BadInputsThrow) {
  TwinStep step;
  step.index = 3;
  EXPECT_THAT([&] { IncipientTruthOf(step, 0.5, 0.25); },
              ::testing::ThrowsMessage<Error>(HasSubstr("step 3 has no surface tractions")));
  step.surface.states = {ContactState::kStick};
  EXPECT_THAT([&] { IncipientTruthOf(step, 0.0, 0.25); },
              ::testing::ThrowsMessage<Error>(HasSubstr("mu must be > 0, got 0")));
  EXPECT_THAT([&] { IncipientTruthOf(step, 0.5, IncipientTruth::kNaN); },
              ::testing::ThrowsMessage<Error>(HasSubstr("cell_area_mm2 must be > 0")));
}

TEST(IncipientEvaluationOptions, BadOptionsNameTheField) {
  IncipientEvaluationOptions o;
  o.window_from = 0.95;
  EXPECT_THAT([&] { EvaluateIncipient("x", {}, 0.0, true, o); },
              ::testing::ThrowsMessage<Error>(HasSubstr("window_from must be in [0, window_to), got 0.95")));
  o = {};
  o.within_mu = 0.0;
  EXPECT_THAT([&] { o.Validate(); }, ::testing::ThrowsMessage<Error>(HasSubstr("within_mu must be > 0")));
  o = {};
  o.target_coverage = 1.5;
  EXPECT_THAT([&] { o.Validate(); },
              ::testing::ThrowsMessage<Error>(HasSubstr("target_coverage must be in (0, 1], got 1.5")));
}

}  // namespace
}  // namespace tac3d
