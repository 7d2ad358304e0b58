// The full `tac3d eval force` run on the default sensor (labelled eval: builds the nominal H and
// the finer true model):  ctest --test-dir build -L eval -R force/ --output-on-failure -V
#include <cstdio>

#include <gtest/gtest.h>

#include "tac3d/eval/force_evaluation.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

TEST(EvaluateForce, DefaultOptionsMeetTheAcceptance) {
  EvalForceOptions options;
  options.cache_dir = testing::MakeTempDir("cache");
  const nlohmann::json report = EvaluateForce(options);
  std::printf("%s\n", report.dump(2).c_str());
  for (const auto& check : report.at("checks")) {
    EXPECT_TRUE(check.at("pass").get<bool>()) << check.dump();
  }
  EXPECT_TRUE(report.at("all_pass").get<bool>());
}

}  // namespace
}  // namespace tac3d
