#include "tac3d/eval/replay_evaluation.h"
#include "tac3d/eval/conditions_evaluation.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/force/test_compliance.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

// A small synthetic twin dataset: rendered images of markers displaced by D = H F for known
// presses F, with the synthetic half-space H standing in for both the twin and the nominal
// model, so the replay's figures have an exact truth to be judged against.

namespace tac3d {
namespace {

using testing::DefaultSensor;
using testing::DefaultSyntheticCompliance;

using ::testing::HasSubstr;

// A Gaussian press (sigma 2 mm about (2, -1) mm) of total force `total_n` on the rest grid.
std::vector<Eigen::Vector3d> PressForces(const Eigen::Vector3d& total_n) {
  const std::vector<Eigen::Vector3d> markers = DefaultSensor().MarkerPositions();
  std::vector<double> weights;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : markers) {
    weights.push_back(std::exp(-(p.head<2>() - Eigen::Vector2d(2, -1)).squaredNorm() / 8.0));
    sum += weights.back();
  }
  std::vector<Eigen::Vector3d> forces;
  for (double w : weights) forces.push_back(total_n * w / sum);
  return forces;
}

// Writes `reference` unloaded steps then one step per load, with images and the truth.
std::string WriteDataset(const std::string& name, int reference, const std::vector<Eigen::Vector3d>& loads) {
  const std::string dir = testing::MakeTempDir("replay") + "/" + name;
  TwinDatasetWriter writer(dir, {{"name", name}, {"scene", "pins"}});
  const MarkerImageRenderer renderer(DefaultSensor());
  const std::vector<Eigen::Vector3d> rest = DefaultSensor().MarkerPositions();
  const int n = static_cast<int>(rest.size());
  std::vector<Eigen::Vector3d> all(reference, Eigen::Vector3d::Zero());
  all.insert(all.end(), loads.begin(), loads.end());
  for (int k = 0; k < static_cast<int>(all.size()); ++k) {
    TwinStep step;
    step.index = k;
    step.t_s = 0.01 * k;
    step.marker_forces_n = PressForces(all[k]);
    Eigen::VectorXd f(3 * n);
    for (int i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) f[a * n + i] = step.marker_forces_n[i][a];
    }
    const Eigen::VectorXd d = DefaultSyntheticCompliance() * f;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = rest[i] + Eigen::Vector3d(d[i], d[n + i], d[2 * n + i]);
      step.marker_positions_mm.push_back(p);
      step.marker_contact.push_back(-step.marker_forces_n[i].z() > 0.01);
      step.marker_slip.push_back(0);
      step.total_force_n += step.marker_forces_n[i];
      step.total_moment_nmm += p.cross(step.marker_forces_n[i]);
    }
    step.image = renderer.Render(step.marker_positions_mm, k);
    writer.Write(step);
  }
  return dir;
}

ReplayOptions ReplayWithFiveReferenceFrames() {
  ReplayOptions options;
  options.pipeline.reference_frames = 5;
  return options;
}

TEST(ReplayEvaluation, RecoversTheTruthOfASyntheticDatasetAndItsGains) {
  const std::vector<Eigen::Vector3d> loads = {{0.4, 0, -1.5}, {0.8, -0.3, -3}, {0, 0, 0}, {-0.5, 0.6, -4.5}};
  const TwinDatasetReader dataset(WriteDataset("press", 5, loads));
  const SensorConfig sensor = DatasetSensor(dataset);
  int calls = 0;
  const ReplayResult r = ReplayTwinDataset(dataset, sensor, DefaultSyntheticCompliance(), DefaultSensor().MarkerPositions(),
                                           ReplayWithFiveReferenceFrames(), [&calls](int done, int all) {
                                             ++calls;
                                             EXPECT_EQ(all, 9);
                                             EXPECT_EQ(done, calls);
                                           });
  EXPECT_EQ(calls, 9);
  ASSERT_EQ(r.frames.size(), 4u);
  const ReplaySummary& s = r.summary;
  EXPECT_EQ(s.steps, 9);
  EXPECT_EQ(s.loaded_frames, 3);
  EXPECT_FALSE(r.frames[2].loaded);
  EXPECT_EQ(s.flagged_frames, 0);
  EXPECT_EQ(s.lost_marker_frames, 0);
  std::printf("max error %% FS %s, rms %s; position RMSE %.4f mm, displacement RMSE %.4f mm, contact IoU %.3f\n",
              ::testing::PrintToString(s.force_error_max_pct_fs.transpose()).c_str(),
              ::testing::PrintToString(s.force_error_rms_pct_fs.transpose()).c_str(), s.position_rmse_mm,
              s.displacement_rmse_mm, s.contact_iou);
  // The pipeline test's 3 N press comes back within 0.1%; 2% FS is the acceptance.
  EXPECT_LT(s.force_error_max_pct_fs.maxCoeff(), 2.0);
  EXPECT_LE(s.force_error_rms_pct_fs.maxCoeff(), s.force_error_max_pct_fs.maxCoeff());
  EXPECT_LT(s.displacement_rmse_mm, 0.01);
  EXPECT_LT(s.position_rmse_mm, 0.05);
  EXPECT_GT(s.contact_agreement, 0.8);
  EXPECT_TRUE(ToJson(s, ReplayWithFiveReferenceFrames()).at("all_pass").get<bool>());

  // Pairs over the loaded frames fit unit gains; doubled gains are seen in the pairs'
  // measured side as the unit-gain resultant again.
  const std::vector<ForcePair> pairs = ReplayForcePairs(r, Eigen::Vector3d::Ones());
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[1].reference_n, r.frames[1].true_force_n);
  const ForceGainFit fit = FitForceGains(ParseForcePairs(ForcePairsToCsv(pairs)));
  EXPECT_THAT(fit.gains, EigenNear(Eigen::Vector3d::Ones(), 0.05));

  ReplayOptions doubled = ReplayWithFiveReferenceFrames();
  doubled.pipeline.force.gains = {1, 1, 2};
  const ReplayResult off = ReplayTwinDataset(dataset, sensor, DefaultSyntheticCompliance(), DefaultSensor().MarkerPositions(), doubled);
  EXPECT_NEAR(off.frames[3].measured_force_n.z(), 2 * r.frames[3].measured_force_n.z(), 1e-9);
  EXPECT_GT(off.summary.force_error_max_pct_fs.z(), 40.0);  // 4.5 N too much of 10 N
  EXPECT_EQ(off.summary.worst_force_step, 8);
  const nlohmann::json j = ToJson(off.summary, doubled);
  EXPECT_FALSE(j.at("all_pass").get<bool>());
  EXPECT_FALSE(j.at("checks")[2].at("pass").get<bool>());
  EXPECT_THAT(ReplayForcePairs(off, doubled.pipeline.force.gains)[2].measured_n,
              EigenNear(pairs[2].measured_n, 1e-9));
  const std::string csv = ReplayFramesToCsv(r.frames);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5);
}

TEST(ReplayEvaluation, RefusesADatasetLoadedDuringTheReference) {
  const TwinDatasetReader dataset(WriteDataset("early", 3, {{0, 0, -2}, {0, 0, -2}, {0, 0, -2}}));
  try {
    ReplayTwinDataset(dataset, DefaultSensor(), DefaultSyntheticCompliance(), DefaultSensor().MarkerPositions(), ReplayWithFiveReferenceFrames());
    FAIL() << "a dataset loaded at step 3 of a 5-frame reference was replayed";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("step 3 carries a force of 2 N"));
    EXPECT_THAT(e.what(), HasSubstr("first 5 steps"));
  }
  ReplayOptions too_short = ReplayWithFiveReferenceFrames();
  too_short.max_steps = 5;
  EXPECT_THROW(too_short.Validate(), Error);
}

// `tac3d eval conditions` (conditions_evaluation.h) on the synthetic dataset: a one-minute
// session at the realistic levels, each nuisance alone, all together and a sensor built at
// tolerance; with the creep re-zeroed every case holds the acceptance bounds, without it the
// creep's case does not.
TEST(ConditionsEvaluation, EachNuisanceAndAllTogetherHoldTheBoundsOnlyWithTheDriftHandled) {
  const TwinDatasetReader dataset(WriteDataset("conditions", 5, {{0.4, 0, -1.5}, {0.8, -0.3, -3}, {-0.5, 0.6, -4.5}}));
  ConditionsEvaluationOptions options;
  options.replay = ReplayWithFiveReferenceFrames();
  options.replay.pipeline.drift.mode = DriftMode::kRezero;
  options.levels.session_s = 60.0;  // the 0.02 mm creep 10 x faster than over 10 minutes
  options.rest_frame_s = 2.0;
  options.calibration_views = 8;
  const ConditionsEvaluation e = EvaluateConditions(dataset, DefaultSensor(), DefaultSyntheticCompliance(), DefaultSensor().MarkerPositions(), options);
  // nominal, six nuisances, all, the three real-image nuisances, real_image, spread
  ASSERT_EQ(e.cases.size(), 13u);
  EXPECT_EQ(e.cases[7].name, "all");
  EXPECT_EQ(e.cases[10].name, "compression");
  EXPECT_EQ(e.cases[10].render.jpeg_quality, 85);
  EXPECT_EQ(e.cases[11].name, "real_image");
  EXPECT_FALSE(e.cases[11].render.led_colour.IsWhite());
  for (const ConditionsCase& c : e.cases) {
    const ReplaySummary& s = c.summary;
    std::printf("%-22s resultant error max %% FS %.3f %.3f %.3f, displacement RMSE %.4f mm, lost %ld, flagged %d\n",
                c.name.c_str(), s.force_error_max_pct_fs.x(), s.force_error_max_pct_fs.y(),
                s.force_error_max_pct_fs.z(), s.displacement_rmse_mm, s.lost_marker_frames, s.flagged_frames);
    EXPECT_EQ(s.loaded_frames, 3) << c.name;
    EXPECT_EQ(s.lost_marker_frames, 0) << c.name;
    EXPECT_LE(s.force_error_max_pct_fs.maxCoeff(), 2.0) << c.name;
    EXPECT_LE(s.displacement_rmse_mm, 0.01) << c.name;
  }
  EXPECT_EQ(e.cases.back().name, "spread");
  EXPECT_TRUE(ToJson(e, options).at("all_pass").get<bool>());

  ConditionsEvaluationOptions untracked = options;
  untracked.replay.pipeline.drift.mode = DriftMode::kFlag;
  untracked.spread = false;
  untracked.real_image = false;
  const ConditionsEvaluation raw = EvaluateConditions(dataset, DefaultSensor(), DefaultSyntheticCompliance(), DefaultSensor().MarkerPositions(), untracked);
  const ConditionsCase& creep = raw.cases[6];
  ASSERT_EQ(creep.name, "creep");
  std::printf("creep flagged, not re-zeroed: displacement RMSE %.4f mm, Fz error %.2f %% FS, drift_at_rest on %d of 3 frames\n",
              creep.summary.displacement_rmse_mm, creep.summary.force_error_max_pct_fs.z(),
              creep.summary.flag_counts[7].second);
  EXPECT_GT(creep.summary.displacement_rmse_mm, 0.015);
  EXPECT_EQ(creep.summary.flag_counts[7].first, "drift_at_rest");
  EXPECT_EQ(creep.summary.flag_counts[7].second, 3);
  EXPECT_FALSE(ToJson(raw, untracked).at("all_pass").get<bool>());
  options.rest_frame_s = 0;
  EXPECT_THROW(options.Validate(), Error);
}

TEST(ReplayEvaluation, OptionsAndHeadersAreChecked) {
  ReplayOptions o;
  EXPECT_NO_THROW(o.Validate());
  o.full_scale_normal_n = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.loaded_force_n = -1;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.max_steps = -1;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.pipeline.reference_frames = 0;
  EXPECT_THROW(o.Validate(), Error);

  const std::string dir = testing::MakeTempDir("replay") + "/no_scene";
  TwinDatasetWriter(dir, {{"name", "x"}});
  EXPECT_THAT([&] { DatasetSensor(TwinDatasetReader(dir)); },
              ::testing::ThrowsMessage<Error>(HasSubstr("--config")));
}

}  // namespace
}  // namespace tac3d
