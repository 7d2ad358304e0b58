#include "tac3d/simulation/twin_measurement.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "tac3d/sensor/test_sensor.h"
#include "tac3d/simulation/test_scenes.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/vendor_gel.h"

namespace tac3d::simulation {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;
using testing::SmallTwinBody;
using testing::SphereScene;

// The pipeline's compliance of the small sensor, as `tac3d run` has it, one model for the
// program (as fem::LoadSharedComplianceModel gives a process).
std::shared_ptr<const fem::ComplianceModel> SmallCompliance() {
  static const auto model = std::make_shared<const fem::ComplianceModel>(
      fem::CalcComplianceModel(SensorBodyModelOptions(testing::SmallSensor())));
  return model;
}

// A sphere 0.05 mm above the fingertip at t = 0, pressed 0.1 mm into it by t = 1 and slid
// 0.3 mm along x by t = 2: 11 steps.
Scene PressAndSlide() {
  return SphereScene({{0.0, {0, 0, -0.05}}, {1.0, {0, 0, 0.1}}, {2.0, {0.3, 0, 0.1}}}, 11);
}

PipelineOptions SmallPipelineOptions() {
  PipelineOptions options = DefaultPipelineOptions(testing::SmallSensor());
  options.reference_frames = 5;
  return options;
}

TEST(TwinSimulation, RenderAtRestDrawsTheUnloadedSensorBeforeStepZero) {
  const TwinSimulation sim(PressAndSlide(), SmallTwinBody());
  const std::vector<Frame> rest = sim.RenderAtRest(3);
  ASSERT_EQ(rest.size(), 3u);
  for (int r = 0; r < 3; ++r) {
    EXPECT_EQ(rest[r].index, r - 3);
    EXPECT_DOUBLE_EQ(rest[r].timestamp_s, (r - 3) * kRestFramePeriodS);
    EXPECT_EQ(rest[r].image.type(), CV_8UC1);
  }
  // The same scene, noise of its own: the frames differ, but by the noise only (a few DN).
  const double mean_abs =
      cv::norm(rest[0].image, rest[1].image, cv::NORM_L1) / rest[0].image.total();
  EXPECT_GT(mean_abs, 0.0);
  EXPECT_LT(mean_abs, 5.0);
  EXPECT_EQ(sim.summary().steps, 0);
  EXPECT_THAT([&] { sim.RenderAtRest(0); }, ThrowsMessage<Error>(HasSubstr("count = 0")));
  SimulationOptions no_images;
  no_images.render_images = false;
  const TwinSimulation blind(PressAndSlide(), SmallTwinBody(), no_images);
  EXPECT_THAT([&] { blind.RenderAtRest(3); },
              ThrowsMessage<Error>(HasSubstr("simulated without images")));
}

TEST(TwinMeasurement, IsThePipelineOnTheRenderedImagesAndTracksTheTruth) {
  TwinSimulation sim(PressAndSlide(), SmallTwinBody());
  TwinMeasurement measurement(testing::SmallSensor(), SmallCompliance(), SmallPipelineOptions());
  const std::vector<Frame> reference = measurement.TakeReference(sim);
  ASSERT_EQ(reference.size(), 5u);
  std::vector<TwinStep> steps;
  std::vector<TactileFrame> measured;
  sim.Run([&](const TwinStep& step) {
    steps.push_back(step);
    measured.push_back(measurement.Measure(step));
  });
  ASSERT_EQ(measured.size(), 11u);

  // A replay: the same images through a pipeline of the same options give the same frames.
  Pipeline replay(testing::SmallSensor(),
                  SmallCompliance()->h,
                  SmallCompliance()->marker_positions,
                  SmallPipelineOptions());
  TactileFrame out;
  for (const Frame& frame : reference) replay.Process(frame, out);
  for (size_t k = 0; k < steps.size(); ++k) {
    replay.Process(Frame{steps[k].image, steps[k].t_s, steps[k].index}, out);
    EXPECT_EQ(out, measured[k]) << "step " << k;
  }

  // Every step measured past the reference, and what it measures follows the truth: nothing
  // at step 0 (clear of the ball), the press's normal force within a factor of 2 (9 markers
  // make a coarse inverse), the markers where the twin put them.
  for (const TactileFrame& f : measured) {
    EXPECT_EQ(f.initialize_progress, 100);
    EXPECT_FALSE(f.has(FrameFlag::kInitializing));
  }
  EXPECT_LT(measured[0].resultant_force_n.norm(), 0.01);
  const TwinStep& pressed = steps[5];
  ASSERT_LT(pressed.total_force_n.z(), -0.05);
  EXPECT_LT(measured[5].resultant_force_n.z(), 0.5 * pressed.total_force_n.z());
  EXPECT_GT(measured[5].resultant_force_n.z(), 2.0 * pressed.total_force_n.z());
  for (int i = 0; i < 9; ++i) {
    EXPECT_TRUE(measured[5].valid[i]);
    EXPECT_LT((measured[5].positions_mm[i] - pressed.marker_positions_mm[i]).norm(), 0.05) << i;
  }
  // Slid along x: the ball drags the fingertip along -x (its motion relative to the sensor).
  EXPECT_LT(steps[10].total_force_n.x(), -0.01);
  EXPECT_LT(measured[10].resultant_force_n.x(), 0.0);
}

// The episodes a process measures with one model (a Dask worker's) hold its H and one inverse
// (K, M, H^T H), not a copy each; another weight has an inverse of its own on the same H.
TEST(TwinMeasurement, MeasurementsOfOneModelShareItsHAndInverse) {
  const std::shared_ptr<const fem::ComplianceModel> model = SmallCompliance();
  const TwinMeasurement first(testing::SmallSensor(), model, SmallPipelineOptions());
  const TwinMeasurement second(testing::SmallSensor(), model, SmallPipelineOptions());
  EXPECT_EQ(&first.pipeline().inverse(), &second.pipeline().inverse());
  EXPECT_EQ(&first.pipeline().inverse().h(), &model->h);
  PipelineOptions heavier = SmallPipelineOptions();
  heavier.force.weight *= 2.0;
  const TwinMeasurement reweighted(testing::SmallSensor(), model, heavier);
  EXPECT_NE(&reweighted.pipeline().inverse(), &first.pipeline().inverse());
  EXPECT_EQ(&reweighted.pipeline().inverse().h(), &model->h);

  // A measurement holds its model: no reference to one freed under it.
  auto own = std::make_shared<const fem::ComplianceModel>(*model);
  const std::weak_ptr<const fem::ComplianceModel> own_alive = own;
  const TwinMeasurement holder(testing::SmallSensor(), own, SmallPipelineOptions());
  own.reset();
  ASSERT_FALSE(own_alive.expired());
  EXPECT_EQ(&holder.pipeline().inverse().h(), &own_alive.lock()->h);
  EXPECT_THAT([] { TwinMeasurement(testing::SmallSensor(), nullptr, SmallPipelineOptions()); },
              ThrowsMessage<Error>(HasSubstr("no compliance model")));
}

TEST(TwinMeasurement, RefusesAStepWithoutImage) {
  TwinSimulation sim(PressAndSlide(), SmallTwinBody());
  TwinMeasurement measurement(testing::SmallSensor(), SmallCompliance(), SmallPipelineOptions());
  measurement.TakeReference(sim);
  TwinStep step = sim.Step();
  step.image = cv::Mat();
  EXPECT_THAT([&] { measurement.Measure(step); },
              ThrowsMessage<Error>(HasSubstr("step 0 has no image")));
}

}  // namespace
}  // namespace tac3d::simulation
