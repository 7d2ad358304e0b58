#include "tac3d/eval/marker_evaluation.h"

#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"

// The chain of `eval markers` on the designed sensor, known exactly (no calibration): what
// tracking and stereo alone contribute. The calibrated run is eval_markers_test (label eval).

namespace tac3d {
namespace {

TEST(EvaluateMarkers, TrackingAndCompensatedStereoMeetTheAcceptanceOnTheKnownSensor) {
  MarkerEvaluationOptions options;
  options.calibrate = false;
  const MarkerEvaluation e = EvaluateMarkers(options);
  std::printf("%s\n%s", ToJson(e).dump().c_str(), e.Report().c_str());
  // Every check the evaluation promises is there: a loop over nothing would pass.
  std::vector<std::string> names;
  for (const EvalCheck& check : e.checks) {
    names.push_back(check.name);
    EXPECT_TRUE(check.pass) << check.Format();
  }
  EXPECT_EQ(names, (std::vector<std::string>{"position_rmse_mm", "displacement_rmse_mm"}));
  EXPECT_EQ(e.markers, 400);
  EXPECT_EQ(e.min_valid_markers, 400);
  EXPECT_FALSE(e.calibration.has_value());
  ASSERT_EQ(e.motions.size(), 3u);
  for (size_t i = 0; i < e.motions.size(); ++i) {
    EXPECT_EQ(e.motions[i].name, options.motions[i].name);
    EXPECT_EQ(e.motions[i].valid_markers, 400) << e.motions[i].name;
  }
  for (const MarkerErrors* model : {&e.by_model.polynomial, &e.by_model.exact}) {
    EXPECT_LE(model->position_rmse_mm, 0.02);
    EXPECT_LE(model->displacement_rmse_mm, 0.01);
  }
  EXPECT_DOUBLE_EQ(e.checks[0].value, e.by_model.polynomial.position_rmse_mm);
  EXPECT_DOUBLE_EQ(e.checks[1].value, e.by_model.polynomial.displacement_rmse_mm);
  // Without compensation the glass and silicone shift every marker by millimetres.
  EXPECT_GT(e.by_model.none.position_rmse_mm, 0.5);
  EXPECT_TRUE(e.all_pass);
}

// Issue 24: the frames rendered with a real camera's nuisances (coloured uneven LEDs, blur
// 1.0 px, JPEG quality 85; RenderOptions::WithRealImageNuisances) still meet the marker
// acceptance, every marker valid.
TEST(EvaluateMarkers, RealImageNuisancesStillMeetTheAcceptanceOnTheKnownSensor) {
  MarkerEvaluationOptions options;
  options.calibrate = false;
  options.real_image_nuisances = true;
  const MarkerEvaluation e = EvaluateMarkers(options);
  std::printf("%s", e.Report().c_str());
  EXPECT_TRUE(e.real_image_nuisances);
  EXPECT_TRUE(ToJson(e).at("real_image_nuisances").get<bool>());
  ASSERT_EQ(e.checks.size(), 2u);
  EXPECT_LE(e.by_model.polynomial.position_rmse_mm, 0.02);
  EXPECT_LE(e.by_model.polynomial.displacement_rmse_mm, 0.01);
  EXPECT_EQ(e.min_valid_markers, 400);
  EXPECT_TRUE(e.all_pass);
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
