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
  const ForceEvaluation evaluation = EvaluateForce(options);
  std::printf("%s\n%s", ToJson(evaluation).dump(2).c_str(), evaluation.Report().c_str());
  ASSERT_EQ(evaluation.checks.size(), 4u);
  for (const EvalCheck& check : evaluation.checks) EXPECT_TRUE(check.pass) << check.Format();
  EXPECT_TRUE(evaluation.all_pass);
}

}  // namespace
}  // namespace tac3d
