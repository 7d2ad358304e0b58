#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tac3d/eval/marker_evaluation.h"

// The marker acceptance (ctest label `eval`): calibrated from rendered boards of a
// perturbed sensor, then the marker layer under shear, dent and twist through the gel.

namespace tac3d {
namespace {

TEST(EvaluateMarkers, MeetsTheAcceptanceOnThreeCalibratedSensors) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    MarkerEvaluationOptions options;
    options.calibration.seed = seed;
    const MarkerEvaluation e = EvaluateMarkers(options);
    std::printf("seed %d: %s\n%s", static_cast<int>(seed), ToJson(e).dump().c_str(), e.Report().c_str());
    // Every check the evaluation promises is there: a loop over nothing would pass.
    std::vector<std::string> names;
    for (const EvalCheck& check : e.checks) {
      names.push_back(check.name);
      EXPECT_TRUE(check.pass) << check.Format();
    }
    EXPECT_EQ(names, (std::vector<std::string>{"position_rmse_mm", "displacement_rmse_mm"}));
    EXPECT_EQ(e.min_valid_markers, 400);
    EXPECT_LE(e.by_model.polynomial.position_rmse_mm, 0.02);
    EXPECT_LE(e.by_model.polynomial.displacement_rmse_mm, 0.01);
    ASSERT_TRUE(e.calibration.has_value());
    EXPECT_EQ(e.calibration_seed, seed);
    EXPECT_TRUE(e.all_pass);
  }
}

}  // namespace
}  // namespace tac3d
