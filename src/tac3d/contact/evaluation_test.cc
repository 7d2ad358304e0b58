#include "tac3d/contact/evaluation.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

// The acceptance cases at a coarse grid (a / h = 10), fast enough for every build; the figures
// still fail if the solver or the influence coefficients break.
TEST(EvaluateContact, CoarseGridMeetsTheAcceptance) {
  EvalContactOptions options;
  options.cells_per_radius = 10.0;
  const nlohmann::json report = EvaluateContact(options);
  std::printf("%s\n", report.dump(1).c_str());
  for (const auto& check : report.at("checks")) {
    EXPECT_TRUE(check.at("pass").get<bool>()) << check.dump();
  }
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
