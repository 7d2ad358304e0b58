// The acceptance run at a fine grid (labelled eval):
//   ctest --test-dir build -L eval -R contact/ --output-on-failure -V
#include <gtest/gtest.h>

#include <cstdio>

#include "tac3d/contact/evaluation.h"

namespace tac3d::contact {
namespace {

TEST(EvaluateContact, FineGridMeetsTheAcceptance) {
  EvalContactOptions options;
  options.cells_per_radius = 32.0;
  const nlohmann::json report = EvaluateContact(options);
  std::printf("%s\n", report.dump(2).c_str());
  for (const auto& check : report.at("checks")) {
    EXPECT_TRUE(check.at("pass").get<bool>()) << check.dump();
  }
}

}  // namespace
}  // namespace tac3d::contact
