#include "tac3d/eval/marker_evaluation.h"

#include <cstdio>

#include <gtest/gtest.h>

#include "tac3d/util/error.h"

// The chain of `eval markers` on the designed sensor, known exactly (no calibration): what
// tracking and stereo alone contribute. The calibrated run is eval_markers_test (label eval).

namespace tac3d {
namespace {

TEST(EvaluateMarkers, TrackingAndCompensatedStereoMeetTheAcceptanceOnTheKnownSensor) {
  MarkerEvaluationOptions options;
  options.calibrate = false;
  const nlohmann::json j = EvaluateMarkers(options);
  std::printf("%s\n", j.dump().c_str());
  EXPECT_EQ(j["min_valid_markers"].get<int>(), 400);
  ASSERT_EQ(j["motions"].size(), 3u);
  for (const char* model : {"polynomial", "exact"}) {
    EXPECT_LE(j["by_model"][model]["position_rmse_mm"].get<double>(), 0.02) << model;
    EXPECT_LE(j["by_model"][model]["displacement_rmse_mm"].get<double>(), 0.01) << model;
  }
  EXPECT_DOUBLE_EQ(j["position_rmse_mm"].get<double>(),
                   j["by_model"]["polynomial"]["position_rmse_mm"].get<double>());
  // Without compensation the glass and silicone shift every marker by millimetres.
  EXPECT_GT(j["by_model"]["none"]["position_rmse_mm"].get<double>(), 0.5);
  EXPECT_TRUE(j["pass"].get<bool>());
}

TEST(MarkerEvaluationOptions, RefusesNoMotionsAndBadReferenceCounts) {
  MarkerEvaluationOptions options;
  options.calibrate = false;
  options.motions.clear();
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.reference_frames = 0;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.calibration.views = 3;
  EXPECT_THROW(options.Validate(), Error);
}

}  // namespace
}  // namespace tac3d
