// The full `tac3d eval fem` run on the default sensor (labelled eval: ~10 min, ~6 GB):
//   ctest --test-dir build-fem -L eval -R fem/ --output-on-failure -V
#include <gtest/gtest.h>

#include <cstdio>

#include "tac3d/fem/compliance.h"
#include "tac3d/fem/evaluation.h"
#include "tac3d/testing/testing.h"

namespace tac3d::fem {
namespace {

TEST(EvaluateFem, DefaultSensorPassesEveryCheck) {
  EvalFemOptions options;
  options.cache_dir = testing::MakeTempDir("cache");
  const EvalFemResult result = EvaluateFem(options);
  std::printf("%s\n%s", ToJson(result).dump(2).c_str(), result.Report().c_str());
  EXPECT_EQ(result.checks.size(), options.convergence_refinement > 0.0 ? 12u : 11u);
  for (const EvalCheck& check : result.checks) EXPECT_TRUE(check.pass) << check.Format();
  EXPECT_TRUE(result.all_pass);
  // The second call finds the default model in the cache.
  const ComplianceCacheResult cached = LoadOrBuildComplianceModel(options.body, options.cache_dir);
  EXPECT_EQ(cached.status, ComplianceCacheStatus::kLoaded);
  std::printf("cached H loaded in %.3f s\n", cached.elapsed_s);
}

}  // namespace
}  // namespace tac3d::fem
