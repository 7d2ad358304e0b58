// `tac3d eval incipient`: the incipient-slip scene family simulated by the twin, its images run
// through the pipeline, the frames' live friction and margin against the twin's truth.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/eval/incipient_evaluation.h"
#include "tac3d/scene/scene.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "twin_runs.h"

namespace tac3d::cli {
namespace {

// The scenes the options select, in their order (each a family member when mu is 0.3, 0.6 or
// 1.0). The options' values are checked, so every name parses.
std::vector<IncipientSceneSpec> SelectScenes(const std::vector<std::string>& indenters,
                                             const std::vector<double>& mus,
                                             const std::vector<std::string>& loads,
                                             const std::vector<std::string>& ramps,
                                             double frame_rate_hz) {
  std::vector<IncipientSceneSpec> specs;
  for (const std::string& indenter : indenters) {
    for (const double mu : mus) {
      for (const std::string& load : loads) {
        for (const std::string& ramp : ramps) {
          std::optional<IncipientSceneSpec> spec =
              ParseIncipientSceneName(fmt::format("incipient_{}_mu{:g}_{}_{}", indenter, mu, load, ramp));
          TAC3D_DEMAND(spec.has_value());
          spec->frame_rate_hz = frame_rate_hz;
          spec->Validate();
          specs.push_back(*spec);
        }
      }
    }
  }
  return specs;
}

// One frame a line: the truth and the live estimate (NaN where there is none).
std::string FramesCsv(const std::vector<IncipientFrame>& frames) {
  std::string csv =
      "t_s,normal_force_n,tangential_force_n,load_ratio,stick_fraction,stick_area_mm2,state,friction,"
      "friction_sigma,margin,margin_sigma\n";
  for (const IncipientFrame& f : frames) {
    const IncipientTruth& t = f.truth;
    const FrameSlip& e = f.estimate;
    csv += fmt::format("{:.4f},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{},{:.6g},{:.6g},{:.6g},{:.6g}\n", t.t_s,
                       t.normal_force_n, t.tangential_force_n, t.load_ratio, t.stick_fraction(), t.stick_area_mm2,
                       SlipStateName(e.state), e.friction, e.friction_sigma, e.margin, e.margin_sigma);
  }
  return csv;
}

}  // namespace

void RegisterEvalIncipient(CLI::App& eval) {
  struct Args {
    std::vector<std::string> indenters = {"sphere", "cylinder", "punch"};
    std::vector<double> mus = {0.3, 0.6, 1.0};
    std::vector<std::string> loads = {"light", "heavy"};
    std::vector<std::string> ramps = {"slow", "fast"};
    double frame_rate_hz = IncipientSceneSpec{}.frame_rate_hz;
    std::optional<double> twin_refinement;
    std::string datasets;
    std::string out = "out/eval_incipient";
    ReplayArgs replay;  ///< its calibration defaults to DATASETS/force_calibration
    IncipientEvaluationOptions evaluation;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "incipient",
      "The live friction and margin to slip before gross slip: the incipient-slip scenes "
      "(indenter x mu x load x ramp) simulated by the twin, their images through the pipeline, each "
      "frame's estimate against the twin's truth. Without --gains or --calibration the gains are "
      "fitted on DATASETS/force_calibration (simulated if missing)");
  cmd->add_option("--indenters", args->indenters, "of sphere, cylinder, punch")
      ->check(CLI::IsMember({"sphere", "cylinder", "punch"}))
      ->capture_default_str();
  cmd->add_option("--mu", args->mus, "the surfaces' friction coefficients, each in (0, 2]")
      ->capture_default_str();
  cmd->add_option("--loads", args->loads, "of light (pressed 0.25 mm), heavy (0.5 mm)")
      ->check(CLI::IsMember({"light", "heavy"}))
      ->capture_default_str();
  cmd->add_option("--ramps", args->ramps, "of slow (the slide over 2 s), fast (0.5 s)")
      ->check(CLI::IsMember({"slow", "fast"}))
      ->capture_default_str();
  cmd->add_option("--frame-rate", args->frame_rate_hz,
                  "camera frames (twin steps) a second, in [5, 1000]; the motion's times are fixed, so "
                  "a lower rate simulates fewer steps")
      ->capture_default_str();
  AddTwinRefinementOption(cmd, &args->twin_refinement);
  cmd->add_option("--datasets", args->datasets,
                  "folder of the scenes' datasets (DIR/<scene>): reused when complete, else simulated "
                  "there (default OUT/datasets)");
  cmd->add_option("--out", args->out, "per scene frames.csv and evaluation.json; report.json")
      ->capture_default_str();
  AddReplayOptions(cmd, args->replay);
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    if (args->twin_refinement) RequireTwinRefinement(*args->twin_refinement);
    for (const double mu : args->mus) {
      if (!(mu > 0.0 && mu <= 2.0)) throw Error(fmt::format("--mu must be in (0, 2], got {}", mu));
    }
    if (!(args->frame_rate_hz >= 5.0 && args->frame_rate_hz <= 1000.0)) {
      throw Error(fmt::format("--frame-rate must be in [5, 1000], got {}", args->frame_rate_hz));
    }
    if (args->replay.max_steps != 0) {
      throw Error("--steps: the evaluation needs every step of a scene (its gross slip comes last); "
                  "use --frame-rate for fewer steps");
    }
    const std::vector<IncipientSceneSpec> specs =
        SelectScenes(args->indenters, args->mus, args->loads, args->ramps, args->frame_rate_hz);
    const std::string datasets = args->datasets.empty() ? args->out + "/datasets" : args->datasets;
    MakeDirectory(datasets);
    MakeDirectory(args->out);
    ReplayArgs replay = args->replay;
    replay.show_progress = true;  // on stderr
    const auto simulate = [&](const std::string& scene, const std::string& folder) {
      SimulateArgs sim;
      sim.scene = scene;
      sim.out = folder;
      sim.cache_dir = replay.cache_dir;
      sim.twin_refinement = args->twin_refinement;
      return EnsureTwinDataset(sim);
    };
    nlohmann::json report = {{"datasets", datasets}, {"frame_rate_hz", args->frame_rate_hz}};
    GainsFittedOnce gains(replay, datasets, args->twin_refinement);
    std::vector<IncipientEvaluation> results;
    nlohmann::json scenes = nlohmann::json::array();
    for (const IncipientSceneSpec& spec : specs) {
      const std::string name = spec.Name();
      const std::string folder = datasets + "/" + name;
      const double simulate_s = simulate(name, folder);
      const TwinDatasetReader reader(folder);
      const nlohmann::json& grid = reader.header().at("twin_body").at("grid");
      const double cell_area_mm2 = grid.at("dx_mm").get<double>() * grid.at("dy_mm").get<double>();
      std::vector<IncipientFrame> frames;
      const ReplayRun run =
          gains.Replay(folder, report, [&](const TwinStep& truth, const TactileFrame& frame) {
            const TwinStep with_surface = reader.Read(truth.index, /*with_surface=*/true);
            frames.push_back({IncipientTruthOf(with_surface, spec.mu, cell_area_mm2), frame.slip});
          });
      IncipientEvaluation e = EvaluateIncipient(name, frames, spec.ramp_start_s(),
                                                spec.ramp == IncipientSceneSpec::Ramp::kSlow, args->evaluation);
      nlohmann::json j = ToJson(e, args->evaluation);
      j["simulate_s"] = simulate_s;
      j["replay"] = run.report;
      MakeDirectory(args->out + "/" + name);
      WriteTextFileAtomically(args->out + "/" + name + "/frames.csv", FramesCsv(frames));
      WriteTextFileAtomically(args->out + "/" + name + "/evaluation.json", j.dump(2) + "\n");
      results.push_back(std::move(e));
      scenes.push_back(std::move(j));
    }
    const IncipientEvaluation overall = PoolIncipientEvaluations(results);
    report["scenes"] = scenes;
    report["overall"] = ToJson(overall, args->evaluation);
    report["all_pass"] = report["overall"]["all_pass"];
    WriteTextFileAtomically(args->out + "/report.json", report.dump(2) + "\n");
    if (args->json) {
      std::printf("%s\n", report.dump(2).c_str());
      return;
    }
    for (const IncipientEvaluation& e : results) std::printf("%s\n", e.BriefReport().c_str());
    std::printf("%s\n", overall.BriefReport().c_str());
    PrintChecks(report["overall"]["checks"]);
    std::printf("wrote %s/report.json and %s/<scene>/{frames.csv,evaluation.json}\n", args->out.c_str(),
                args->out.c_str());
  });
}

}  // namespace tac3d::cli
