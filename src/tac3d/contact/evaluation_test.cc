#include "tac3d/contact/evaluation.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

// The acceptance cases at a coarse grid (a / h = 10), fast enough for every build; the figures
// still fail if the solver or the influence coefficients break.
TEST(EvaluateContact, CoarseGridMeetsTheAcceptance) {
  EvalContactOptions options;
  options.cells_per_radius = 10.0;
  const EvalContactResult result = EvaluateContact(options);
  std::printf("%s\n%s", ToJson(result).dump(1).c_str(), result.Report().c_str());
  // Every check the evaluation promises is there: a loop over nothing would pass.
  const std::vector<std::string> expected = {
      "hertz_radius_error_pct",  "hertz_peak_error_pct",         "hertz_profile_rms_pct",
      "mindlin_stick_error_pct", "mindlin_shift_error_pct",      "mindlin_full_slide_error_pct",
      "history_residual_shift_error_pct", "slip_mu_error_pct", "all_converged"};
  std::vector<std::string> names;
  for (const EvalCheck& check : result.checks) {
    names.push_back(check.name);
    EXPECT_TRUE(check.pass) << check.Format();
  }
  EXPECT_TRUE(result.all_pass);
  EXPECT_EQ(names, expected);
}

TEST(EvaluateContact, RejectsBadOptions) {
  EvalContactOptions options;
  options.cells_per_radius = 2.0;
  EXPECT_THROW(EvaluateContact(options), Error);
  options = {};
  options.friction_coefficient = -0.1;
  EXPECT_THROW(EvaluateContact(options), Error);
}

}  // namespace
}  // namespace tac3d::contact
