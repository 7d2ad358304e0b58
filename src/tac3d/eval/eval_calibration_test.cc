#include <cstdio>

#include <gtest/gtest.h>

#include "tac3d/eval/calibration_evaluation.h"

// The acceptance figures (ctest label `eval`); the fast tests that can fail for the
// same reasons are in calibration_evaluation_test.

namespace tac3d {
namespace {

TEST(EvaluateCalibration, MeetsTheAcceptanceOnThreeSensorsAndBothBoardLayouts) {
  for (const bool asymmetric : {false, true}) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      TwinCalibrationOptions o;
      o.seed = seed;
      if (asymmetric) {
        o.board.layout = CalibrationBoard::Layout::kAsymmetric;
        o.board.rows = 9;
        o.board.cols = 4;
      }
      const nlohmann::json j = EvaluateCalibration(o);
      std::printf("%s seed %d: %s\n", asymmetric ? "asymmetric" : "symmetric", static_cast<int>(seed),
                  j.dump().c_str());
      EXPECT_EQ(j["views_used"].get<int>(), 21);
      EXPECT_LE(j["reprojection_rms_px"].get<double>(), 0.1);
      EXPECT_LE(j["camera_position_error_mm"]["max"].get<double>(), 0.3);
      EXPECT_LE(j["camera_rotation_error_deg"]["max"].get<double>(), 0.1);
      EXPECT_TRUE(j["pass"].get<bool>());
    }
  }
}

TEST(EvaluateDisplacement, BoardMovesAreMeasuredWithinTheAcceptance) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    DisplacementEvaluationOptions o;
    o.calibration.seed = seed;
    const nlohmann::json j = EvaluateDisplacement(o);
    std::printf("seed %d: %s\n", static_cast<int>(seed), j.dump().c_str());
    for (const char* axis : {"x", "y", "z"}) {
      EXPECT_LE(j["rmse_mm"][axis].get<double>(), 0.01) << axis;
    }
    EXPECT_TRUE(j["pass"].get<bool>());
  }
}

}  // namespace
}  // namespace tac3d
