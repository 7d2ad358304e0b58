#include "tac3d/eval/conditions_evaluation.h"

#include <fmt/format.h>

#include <cmath>

#include "tac3d/calib/virtual_stereo_calibration.h"
#include "tac3d/twin/calibration_set.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"

namespace tac3d {
namespace {

std::vector<ConditionsCase> Cases(const ConditionsEvaluationOptions& options) {
  std::vector<ConditionsCase> cases;
  SessionConditions nominal;
  nominal.session_s = options.levels.session_s;
  const RenderOptions& camera = options.render;
  cases.push_back({"nominal", nominal, camera, false, {}});
  for (const Nuisance n : kAllNuisances) {
    cases.push_back({std::string(ToString(n)), options.levels.Only(n), camera, false, {}});
  }
  cases.push_back({"all", options.levels, camera, false, {}});
  if (options.real_image) {
    const RenderOptions real = camera.WithRealImageNuisances();
    RenderOptions led_colour = camera, blur = camera, compression = camera;
    led_colour.led_colour = real.led_colour;
    blur.blur_sigma_px = real.blur_sigma_px;
    compression.jpeg_quality = real.jpeg_quality;
    cases.push_back({"led_colour", nominal, led_colour, false, {}});
    cases.push_back({"blur", nominal, blur, false, {}});
    cases.push_back({"compression", nominal, compression, false, {}});
    cases.push_back({"real_image", nominal, real, false, {}});
  }
  if (options.spread) cases.push_back({"spread", options.levels, camera, true, {}});
  return cases;
}

// The sensor built at tolerance, and the nominal design calibrated from its board images.
struct SpreadSensor {
  SensorConfig truth;
  SensorConfig calibrated;
};

SpreadSensor CalibrateSpread(const SensorConfig& config,
                             const ConditionsEvaluationOptions& options) {
  SpreadSensor s;
  s.truth =
      PerturbSensor(config, SensorPerturbationOptions::ManufacturingSpread(options.spread_seed));
  CalibrationSetOptions set_options;
  set_options.views = options.calibration_views;
  set_options.seed = options.spread_seed;
  const CalibrationSet set = RenderCalibrationSet(s.truth, set_options);
  s.calibrated = CalibrateVirtualStereo(set.images, set.board_file, config).ApplyTo(config);
  return s;
}

// One case's replay: its images rendered again through `truth` under the session's
// conditions, the pipeline built on `seen`.
ReplaySummary ReplayCase(const TwinDatasetReader& dataset,
                         const SensorConfig& truth,
                         const SensorConfig& seen,
                         const Eigen::MatrixXd& h,
                         const std::vector<Eigen::Vector3d>& fem_markers_mm,
                         const SessionConditions& session,
                         const RenderOptions& camera,
                         const ConditionsEvaluationOptions& options) {
  const MarkerImageRenderer renderer(truth, camera);
  const FrameConditions end = session.At(session.session_s);
  ReplayAlterations alter;
  alter.step = [&](TwinStep& step, bool reference) {
    if (!reference) step.t_s += session.session_s;
    step.image = renderer.Render(step.marker_positions_mm,
                                 static_cast<std::uint64_t>(step.index),
                                 reference ? session.At(0.0) : end);
  };
  alter.after_reference = [&](Pipeline& pipeline, const TwinStep& last) {
    TactileFrame out;
    std::int64_t frame = last.index;
    for (double t = options.rest_frame_s; t < session.session_s; t += options.rest_frame_s) {
      // Frame indices past the dataset's, so the rest frames' noise is their own.
      const std::uint64_t noise_index = static_cast<std::uint64_t>(1'000'000 + ++frame);
      pipeline.Process(Frame{renderer.Render(last.marker_positions_mm, noise_index, session.At(t)),
                             last.t_s + t,
                             frame},
                       out);
    }
  };
  return ReplayTwinDataset(dataset, seen, h, fem_markers_mm, options.replay, {}, {}, alter).summary;
}

}  // namespace

void ConditionsEvaluationOptions::Validate() const {
  replay.Validate();
  levels.Validate();
  render.Validate();
  const OptionCheck require("conditions evaluation");
  require(rest_frame_s > 0 && rest_frame_s <= levels.session_s,
          "rest_frame_s",
          "in (0, levels.session_s]",
          rest_frame_s);
  require(calibration_views >= 6, "calibration_views", ">= 6", calibration_views);
  require(
      max_displacement_rmse_mm > 0, "max_displacement_rmse_mm", "> 0", max_displacement_rmse_mm);
}

ConditionsEvaluation EvaluateConditions(const TwinDatasetReader& dataset,
                                        const SensorConfig& config,
                                        const Eigen::MatrixXd& h,
                                        const std::vector<Eigen::Vector3d>& fem_markers_mm,
                                        const ConditionsEvaluationOptions& options,
                                        const std::function<void(int, int)>& progress) {
  options.Validate();
  ConditionsEvaluation evaluation;
  evaluation.cases = Cases(options);
  const int count = static_cast<int>(evaluation.cases.size());
  for (int c = 0; c < count; ++c) {
    ConditionsCase& one = evaluation.cases[c];
    if (one.spread) {
      const SpreadSensor spread = CalibrateSpread(config, options);
      one.summary = ReplayCase(dataset, spread.truth, spread.calibrated, h, fem_markers_mm,
                               one.conditions, one.render, options);
    } else {
      one.summary = ReplayCase(
          dataset, config, config, h, fem_markers_mm, one.conditions, one.render, options);
    }
    if (progress) progress(c + 1, count);
  }
  return evaluation;
}

nlohmann::json ToJson(const ConditionsEvaluation& evaluation,
                      const ConditionsEvaluationOptions& options) {
  const SessionConditions& l = options.levels;
  nlohmann::json cases = nlohmann::json::array();
  bool all_pass = !evaluation.cases.empty();
  for (const ConditionsCase& c : evaluation.cases) {
    nlohmann::json summary = ToJson(c.summary, options.replay);
    const EvalCheck displacement = EvalCheck::AtMost(
        "displacement_rmse", c.summary.displacement_rmse_mm, options.max_displacement_rmse_mm, "mm");
    const bool displacement_pass = displacement.pass;
    summary["checks"].push_back(ToJson(displacement));
    summary["all_pass"] = summary["all_pass"].get<bool>() && displacement_pass;
    all_pass = all_pass && summary["all_pass"].get<bool>();
    cases.push_back({{"name", c.name},
                     {"spread", c.spread},
                     {"led_colour", c.render.led_colour.IsWhite() ? "white" : "coloured"},
                     {"blur_sigma_px", c.render.blur_sigma_px},
                     {"jpeg_quality", c.render.jpeg_quality},
                     {"replay", summary}});
  }
  return {{"levels",
           {{"session_s", l.session_s},
            {"illumination_gain", l.illumination_gain},
            {"illumination_offset", l.illumination_offset},
            {"illumination_gradient", l.illumination_gradient},
            {"contrast_fade", l.contrast_fade},
            {"exposure_drift", l.exposure_drift},
            {"creep_mm", l.creep_mm}}},
          {"rest_frame_s", options.rest_frame_s},
          {"spread_seed", options.spread_seed},
          {"cases", cases},
          {"all_pass", all_pass}};
}

}  // namespace tac3d
