#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/eval/replay_evaluation.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/twin/session_conditions.h"

namespace tac3d {

/// `tac3d eval conditions`: a twin dataset replayed as if at the end of a session
/// under each nuisance alone, all together, and on a sensor built at tolerance.
struct ConditionsEvaluationOptions {
  /// The replay (the pipeline's options: its drift mode, its lighting flag, its gains).
  ReplayOptions replay;
  /// The nuisances' levels at the session's end (SessionConditions::Realistic by default).
  SessionConditions levels = SessionConditions::Realistic();
  /// Between the reference and the dataset's first later step the sensor rests for
  /// levels.session_s, seen once every this many seconds (the drift handling sees the creep).
  double rest_frame_s = 1.0;
  /// The twin's camera (as the simulation renders: RenderOptions' defaults).
  RenderOptions render;
  /// Also the real-image nuisances (RenderOptions::WithRealImageNuisances of `render`), each
  /// alone and together, with the session's nuisances at nothing.
  bool real_image = true;
  /// Also a sensor built at the manufacturing tolerances (ManufacturingSpread(spread_seed)),
  /// calibrated from `calibration_views` rendered board views.
  bool spread = true;
  std::uint64_t spread_seed = 1;
  int calibration_views = 20;
  /// The acceptance bound on the displacement RMSE (mm), besides the replay's on the force.
  double max_displacement_rmse_mm = 0.01;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// One case's replay: the conditions seen, and the replay's figures.
struct ConditionsCase {
  /// "nominal", a Nuisance's name, "all", "led_colour", "blur", "compression", "real_image",
  /// "spread"
  std::string name;
  SessionConditions conditions;
  RenderOptions render;  ///< the twin's camera in this case
  bool spread = false;
  ReplaySummary summary;
};

struct ConditionsEvaluation {
  std::vector<ConditionsCase> cases;
};

/// Replays `dataset` once per case: the reference steps under nominal conditions at the
/// session's start, then `levels.session_s` of rest (the last reference step's markers,
/// one frame every rest_frame_s, the conditions ramping), then every later step at the
/// session's end (its conditions at their levels, its time moved by session_s). Each image
/// is rendered again from the step's true marker positions (the creep moves the rendered
/// markers, not the truth: the displacement judged is the load's). The cases: nominal,
/// each Nuisance alone, all together, (options.real_image) each real-image nuisance of the
/// camera alone (led_colour, blur, compression) and the three together (real_image), and
/// (options.spread) the session's nuisances together on a sensor built at tolerance, seen
/// through its calibration.
/// @param progress called with (cases done, cases in all), may be empty.
/// @throws Error as ReplayTwinDataset does, if the options are invalid or the calibration fails.
ConditionsEvaluation EvaluateConditions(const TwinDatasetReader& dataset,
                                        const SensorConfig& config,
                                        const Eigen::MatrixXd& h,
                                        const std::vector<Eigen::Vector3d>& fem_markers_mm,
                                        const ConditionsEvaluationOptions& options,
                                        const std::function<void(int, int)>& progress = {});

/// Each case's name, its replay summary (ToJson of ReplaySummary) and its checks (the
/// resultant error and the displacement RMSE within their bounds), and `all_pass`.
nlohmann::json ToJson(const ConditionsEvaluation& evaluation,
                      const ConditionsEvaluationOptions& options);

}  // namespace tac3d
