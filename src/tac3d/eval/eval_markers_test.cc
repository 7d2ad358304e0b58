#include <cstdio>

#include <gtest/gtest.h>

#include "tac3d/eval/marker_evaluation.h"

// The marker acceptance (ctest label `eval`): calibrated from rendered boards of a
// perturbed sensor, then the marker layer under shear, dent and twist through the gel.

namespace tac3d {
namespace {

TEST(EvaluateMarkers, MeetsTheAcceptanceOnThreeCalibratedSensors) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    MarkerEvaluationOptions options;
    options.calibration.seed = seed;
    const nlohmann::json j = EvaluateMarkers(options);
    std::printf("seed %d: %s\n", static_cast<int>(seed), j.dump().c_str());
    EXPECT_EQ(j["min_valid_markers"].get<int>(), 400);
    EXPECT_LE(j["position_rmse_mm"].get<double>(), 0.02);
    EXPECT_LE(j["displacement_rmse_mm"].get<double>(), 0.01);
    EXPECT_TRUE(j["pass"].get<bool>());
  }
}

}  // namespace
}  // namespace tac3d
