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
  const nlohmann::json report = EvaluateFem(options);
  std::printf("%s\n", report.dump(2).c_str());
  for (const auto& check : report.at("checks")) {
    EXPECT_TRUE(check.at("pass").get<bool>()) << check.dump();
  }
  EXPECT_TRUE(report.at("all_pass").get<bool>());
  // The second call finds the default model in the cache.
  const ComplianceCacheResult cached = LoadOrBuildComplianceModel(options.body, options.cache_dir);
  EXPECT_EQ(cached.status, ComplianceCacheStatus::kLoaded);
  std::printf("cached H loaded in %.3f s\n", cached.elapsed_s);
}

}  // namespace
}  // namespace tac3d::fem
