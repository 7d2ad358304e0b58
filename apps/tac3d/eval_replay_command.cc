#include <cstdio>
#include <fstream>
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "tac3d/util/file_io.h"
#include "twin_runs.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/util/eval_check.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"
#include "tac3d/vendor_formats/vendor_gel.h"

namespace tac3d::cli {
namespace {

std::function<void(int, int)> Progress(std::unique_ptr<ProgressBar>& bar, const std::string& label,
                                       bool enabled) {
  return [&bar, label, enabled](int done, int all) {
    if (!bar) bar = std::make_unique<ProgressBar>(label, all, enabled);
    bar->Update(done);
    if (done == all) bar->Finish();
  };
}

}  // namespace

void AddReplayOptions(CLI::App* cmd, ReplayArgs& replay) {
  cmd->add_option("--gains", replay.gains, "force gains Cx Cy Cz (default 1 1 1, or fitted on --calibration)")
      ->expected(3);
  cmd->add_option("--calibration", replay.calibration,
                  "fit the gains on this twin dataset replayed with unit gains");
  cmd->add_option("--min-r-squared", replay.gain_fit.min_r_squared,
                  "with --calibration: the least R^2 a fitted gain is usable with")
      ->capture_default_str();
  cmd->add_option("--config", replay.config, "sensor YAML (default: the dataset's scene's sensor)");
  cmd->add_option("--cache,--cache-dir", replay.cache_dir, "directory of cached compliance models")->capture_default_str();
  cmd->add_option("--steps", replay.max_steps, "replay only the first N steps (0: all)")->capture_default_str();
}

ReplaySetup PrepareReplay(const ReplayArgs& a, const TwinDatasetReader& dataset) {
  if (!a.gains.empty() && !a.calibration.empty()) throw Error("give --gains or --calibration, not both");
  if (!a.gains.empty() && a.gains.size() != 3) throw Error("--gains takes three numbers: Cx Cy Cz");
  ReplaySetup setup;
  setup.config = a.config.empty() ? DatasetSensor(dataset) : LoadSensorConfig(a.config);
  MakeCacheDirectory(a.cache_dir);
  fem::ComplianceCacheResult model = fem::LoadOrBuildComplianceModel(
      SensorBodyModelOptions(setup.config), a.cache_dir, a.show_progress);
  setup.h = std::move(model.model.h);
  setup.fem_markers_mm = std::move(model.model.marker_positions);
  setup.options.max_steps = a.max_steps;
  setup.options.gain_fit = a.gain_fit;
  if (a.max_support_markers != 0) setup.options.pipeline.force.max_support_markers = a.max_support_markers;
  if (!a.gains.empty()) setup.options.pipeline.force.gains = {a.gains[0], a.gains[1], a.gains[2]};
  if (!a.calibration.empty()) {
    std::unique_ptr<ProgressBar> bar;
    setup.calibration = CalibrateGainsByReplay(TwinDatasetReader(a.calibration), setup.config, setup.h,
                                               setup.fem_markers_mm, setup.options,
                                               Progress(bar, "replay calibration", a.show_progress));
    setup.options.pipeline.force.gains = setup.calibration->fit.gains;
  }
  return setup;
}

ReplayRun RunReplay(const ReplayArgs& a, const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame) {
  const TwinDatasetReader dataset(a.dataset);
  ReplaySetup setup = PrepareReplay(a, dataset);
  ReplayRun run;
  run.options = setup.options;
  run.calibration = std::move(setup.calibration);
  std::unique_ptr<ProgressBar> bar;
  run.replay = ReplayTwinDataset(dataset, setup.config, setup.h, setup.fem_markers_mm, run.options,
                                 Progress(bar, "replay", a.show_progress), on_frame);
  run.report = ToJson(run.replay.summary, run.options);
  run.report["dataset"] = a.dataset;
  if (run.calibration) {
    ReplayOptions unit_gains = run.options;
    unit_gains.pipeline.force.gains = Eigen::Vector3d::Ones();
    const ForceGainFit& fit = run.calibration->fit;
    run.report["calibration"] = {{"dataset", a.calibration},
                                 {"fit", ToJson(fit)},
                                 {"replay_with_unit_gains", ToJson(run.calibration->replay.summary, unit_gains)}};
    // A flagged fit fails the run's checks: its forces are scaled by gains fitted to noise.
    run.report["checks"].push_back(ToJson(
        EvalCheck::AtLeast("gain_fit_r_squared_min", fit.r_squared.minCoeff(), fit.min_r_squared)));
    run.report["all_pass"] = run.report["all_pass"].get<bool>() && fit.usable();
  }
  return run;
}

GainsFittedOnce::GainsFittedOnce(const ReplayArgs& replay,
                                 const std::string& datasets,
                                 std::optional<double> twin_refinement)
    : replay_(replay) {
  if (!replay_.gains.empty() || !replay_.calibration.empty()) return;
  replay_.calibration = datasets + "/force_calibration";
  EnsureTwinDataset({.scene = "force_calibration",
                     .out = replay_.calibration,
                     .cache_dir = replay_.cache_dir,
                     .twin_refinement = twin_refinement});
}

ReplayRun GainsFittedOnce::Replay(
    const std::string& dataset,
    nlohmann::json& report,
    const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame) {
  replay_.dataset = dataset;
  ReplayRun run = RunReplay(replay_, on_frame);
  if (run.calibration) {  // fitted once, reused for the other datasets
    replay_.calibration.clear();
    const Eigen::Vector3d& g = run.options.pipeline.force.gains;
    replay_.gains = {g.x(), g.y(), g.z()};
    report["calibration"] = run.report.at("calibration");
  }
  report["gains"] = replay_.gains.empty() ? std::vector<double>{1, 1, 1} : replay_.gains;
  return run;
}

void WriteReplayFiles(const ReplayRun& run, const std::string& folder) {
  MakeDirectory(folder);
  WriteTextFileAtomically(folder + "/report.json", run.report.dump(2) + "\n");
  WriteTextFileAtomically(folder + "/frames.csv", ReplayFramesToCsv(run.replay.frames));
  WriteTextFileAtomically(folder + "/force_pairs.csv",
                ForcePairsToCsv(run.calibration ? run.calibration->pairs
                                                : ReplayForcePairs(run.replay, run.options.pipeline.force.gains)));
}

void RegisterEvalReplay(CLI::App& eval) {
  struct Args {
    ReplayArgs replay;
    std::string out;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "replay",
      "Replay a twin dataset's images through the pipeline and compare every frame with the "
      "truth: resultant force and moment, markers, contact, flags");
  ReplayArgs& r = args->replay;
  cmd->add_option("--dataset", r.dataset, "twin dataset folder (tac3d simulate)")->required();
  AddReplayOptions(cmd, r);
  cmd->add_option("--max-support-markers", r.max_support_markers,
                  "the force re-solve's largest contact support, markers (0: the default, 120)")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "write report.json, frames.csv and force_pairs.csv here");
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    ReplayArgs a = args->replay;
    a.show_progress = ShowProgress(args->json);
    // An evaluation reports a poor fit (a failed check, the fit's warning) rather than stop.
    a.gain_fit.on_poor_fit = PoorGainFit::kFlag;
    const ReplayRun run = RunReplay(a);
    if (!args->out.empty()) WriteReplayFiles(run, args->out);
    const nlohmann::json& j = run.report;
    if (args->json) {
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    if (run.calibration) {
      const ForceGainFit& fit = run.calibration->fit;
      std::printf("gains fitted on %s (%d loaded frames): %.5f %.5f %.5f, R^2 %.5f %.5f %.5f\n",
                  a.calibration.c_str(), fit.num_pairs, fit.gains.x(), fit.gains.y(), fit.gains.z(),
                  fit.r_squared.x(), fit.r_squared.y(), fit.r_squared.z());
      if (!fit.usable()) std::printf("WARNING: unusable gains: %s\n", fit.PoorFitMessage().c_str());
    }
    const ReplaySummary& s = run.replay.summary;
    std::printf("%d steps, %d frames after the reference, %d loaded, %d flagged, %ld lost marker-frames\n",
                s.steps, s.frames, s.loaded_frames, s.flagged_frames, s.lost_marker_frames);
    std::printf("resultant error, %% of full scale, max x y z: %.3f %.3f %.3f, rms: %.3f %.3f %.3f (worst step %d)\n",
                s.force_error_max_pct_fs.x(), s.force_error_max_pct_fs.y(), s.force_error_max_pct_fs.z(),
                s.force_error_rms_pct_fs.x(), s.force_error_rms_pct_fs.y(), s.force_error_rms_pct_fs.z(),
                s.worst_force_step);
    std::printf("moment error, N mm, max x y z: %.3f %.3f %.3f, rms: %.3f %.3f %.3f\n",
                s.moment_error_max_nmm.x(), s.moment_error_max_nmm.y(), s.moment_error_max_nmm.z(),
                s.moment_error_rms_nmm.x(), s.moment_error_rms_nmm.y(), s.moment_error_rms_nmm.z());
    std::printf("markers: position RMSE %.4f mm, displacement RMSE %.4f mm; contact agreement %.3f, IoU %.3f\n",
                s.position_rmse_mm, s.displacement_rmse_mm, s.contact_agreement, s.contact_iou);
    std::printf("frames by flag: %s\n", j.at("frames_by_flag").dump().c_str());
    PrintChecks(j.at("checks"));
    if (!args->out.empty()) std::printf("wrote %s/{report.json,frames.csv,force_pairs.csv}\n", args->out.c_str());
  });
}

}  // namespace tac3d::cli
