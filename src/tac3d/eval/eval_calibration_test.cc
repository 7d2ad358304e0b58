#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tac3d/eval/calibration_evaluation.h"

// The calibration's acceptance figures (ctest label `eval`); the fast tests that can fail for the
// same reasons are in calibration_evaluation_test.

namespace tac3d {
namespace {

// The names of the checks, each expected to pass.
std::vector<std::string> PassingCheckNames(const std::vector<EvalCheck>& checks) {
  std::vector<std::string> names;
  for (const EvalCheck& check : checks) {
    names.push_back(check.name);
    EXPECT_TRUE(check.pass) << check.Format();
  }
  return names;
}

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
      const CalibrationEvaluation e = EvaluateCalibration(o);
      std::printf("%s seed %d: %s\n%s", asymmetric ? "asymmetric" : "symmetric", static_cast<int>(seed),
                  ToJson(e).dump().c_str(), e.Report().c_str());
      EXPECT_EQ(e.summary.views_used, 21);
      // Every check the evaluation promises is there: a loop over nothing would pass.
      EXPECT_EQ(PassingCheckNames(e.checks),
                (std::vector<std::string>{"reprojection_rms_px", "camera_position_error_mm",
                                          "camera_rotation_error_deg"}));
      EXPECT_LE(e.summary.rms_px, 0.1);
      EXPECT_LE(e.camera_position_error_mm.max(), 0.3);
      EXPECT_LE(e.camera_rotation_error_deg.max(), 0.1);
      EXPECT_TRUE(e.all_pass);
    }
  }
}

TEST(EvaluateDisplacement, BoardMovesAreMeasuredWithinTheAcceptance) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    DisplacementEvaluationOptions o;
    o.calibration.seed = seed;
    const DisplacementEvaluation e = EvaluateDisplacement(o);
    std::printf("seed %d: %s\n%s", static_cast<int>(seed), ToJson(e).dump().c_str(), e.Report().c_str());
    EXPECT_EQ(PassingCheckNames(e.checks),
              (std::vector<std::string>{"rmse_x_mm", "rmse_y_mm", "rmse_z_mm"}));
    for (int axis = 0; axis < 3; ++axis) EXPECT_LE(e.rmse_mm[axis], 0.01) << axis;
    EXPECT_EQ(e.dots_per_move, o.calibration.board.rows * o.calibration.board.cols);
    EXPECT_TRUE(e.all_pass);
  }
}

}  // namespace
}  // namespace tac3d
