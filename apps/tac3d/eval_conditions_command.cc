#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "tac3d/eval/conditions_evaluation.h"
#include "tac3d/util/progress.h"
#include "twin_runs.h"

namespace tac3d::cli {

void RegisterEvalConditions(CLI::App& eval) {
  struct Args {
    ReplayArgs replay;
    DriftMode drift = DriftMode::kRezero;
    ConditionsEvaluationOptions options;
    bool no_spread = false;
    bool no_real_image = false;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "conditions",
      "Replay a twin dataset at the end of a session under each nuisance alone, all together and "
      "on a sensor built at tolerance (docs/pipeline.md, \"Lighting and drift\")");
  cmd->add_option("--dataset", args->replay.dataset, "twin dataset folder (tac3d simulate)")
      ->required();
  AddReplayOptions(cmd, args->replay);
  AddDriftOption(cmd, &args->drift, "the pipeline's drift mode: off, flag or rezero (the default here)");
  cmd->add_option("--session",
                  args->options.levels.session_s,
                  "the session's length, s: the nuisances reach their realistic levels at its end")
      ->capture_default_str();
  cmd->add_option("--rest-frame",
                  args->options.rest_frame_s,
                  "a frame every this many seconds while the sensor rests through the session")
      ->capture_default_str();
  cmd->add_flag("--no-spread",
                args->no_spread,
                "leave out the sensor built at tolerance (and its calibration)");
  cmd->add_flag("--no-real-image",
                args->no_real_image,
                "leave out the real-image nuisances' cases (led_colour, blur, compression, real_image)");
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    ReplayArgs a = args->replay;
    a.show_progress = ShowProgress(args->json);
    const TwinDatasetReader dataset(a.dataset);
    const ReplaySetup setup = PrepareReplay(a, dataset);
    ConditionsEvaluationOptions options = args->options;
    options.replay = setup.options;
    options.replay.pipeline.drift.mode = args->drift;
    options.spread = !args->no_spread;
    options.real_image = !args->no_real_image;
    std::unique_ptr<ProgressBar> bar;
    const ConditionsEvaluation e = EvaluateConditions(
        dataset, setup.config, setup.h, setup.fem_markers_mm, options, [&](int done, int all) {
          if (!bar) bar = std::make_unique<ProgressBar>("conditions", all, a.show_progress);
          bar->Update(done);
          if (done == all) bar->Finish();
        });
    nlohmann::json report = ToJson(e, options);
    report["dataset"] = a.dataset;
    if (args->json) {
      std::printf("%s\n", report.dump(2).c_str());
      return;
    }
    std::printf("%-22s %-26s %-26s %-12s %-6s %s\n",
                "case",
                "resultant max % FS x y z",
                "rms % FS x y z",
                "displ. RMSE",
                "lost",
                "frames by flag");
    for (const ConditionsCase& c : e.cases) {
      const ReplaySummary& s = c.summary;
      std::string flags;
      for (const auto& [name, frames] : s.flag_counts) {
        if (frames > 0) flags += fmt::format("{}{} {}", flags.empty() ? "" : ", ", name, frames);
      }
      std::printf("%-22s %7.3f %7.3f %7.3f    %7.3f %7.3f %7.3f    %.4f mm    %-6ld %s\n",
                  c.name.c_str(),
                  s.force_error_max_pct_fs.x(),
                  s.force_error_max_pct_fs.y(),
                  s.force_error_max_pct_fs.z(),
                  s.force_error_rms_pct_fs.x(),
                  s.force_error_rms_pct_fs.y(),
                  s.force_error_rms_pct_fs.z(),
                  s.displacement_rmse_mm,
                  s.lost_marker_frames,
                  flags.empty() ? "none" : flags.c_str());
    }
    std::printf("all cases within 2%% FS and 0.01 mm: %s\n",
                report.at("all_pass").get<bool>() ? "yes" : "no");
  });
}

}  // namespace tac3d::cli
