// The acceptance run at a fine grid (labelled eval):
//   ctest --test-dir build -L eval -R contact/ --output-on-failure -V
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "tac3d/contact/evaluation.h"

namespace tac3d::contact {
namespace {

TEST(EvaluateContact, FineGridMeetsTheAcceptance) {
  EvalContactOptions options;
  options.cells_per_radius = 32.0;
  const EvalContactResult result = EvaluateContact(options);
  std::printf("%s\n%s", ToJson(result).dump(2).c_str(), result.Report().c_str());
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

}  // namespace
}  // namespace tac3d::contact
