// `tac3d eval friction`: the friction-map scenes simulated by the twin, their images run
// through the pipeline, mapped and compared with the scenes' truth.
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "twin_runs.h"
#include "tac3d/util/file_io.h"
#include "friction_command.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/friction_eval/friction_evaluation.h"
#include "tac3d/scene/scene.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"

namespace tac3d::cli {
void RegisterEvalFriction(CLI::App& eval) {
  struct Args {
    std::vector<std::string> scenes = {"friction_block", "friction_bottle", "friction_paint_can",
                                        "friction_tool_handle"};
    std::string datasets;
    std::string out = "out/eval_friction";
    ReplayArgs replay;  ///< the datasets' replay; its calibration defaults to DATASETS/force_calibration
    FrictionMapArgs map;
    FrictionEvaluationOptions evaluation;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "friction",
      "Friction maps of the twin's friction scenes through the whole chain (images -> pipeline -> "
      "map) against the scenes' truth: mu, bands, boundaries, coverage, surface, slip points. Without "
      "--gains or --calibration the gains are fitted on DATASETS/force_calibration (simulated if "
      "missing)");
  cmd->add_option("--scenes", args->scenes, "built-in scenes or scene files")
      ->capture_default_str();
  cmd->add_option(
      "--datasets",
      args->datasets,
      "folder of the scenes' datasets (DIR/<scene>): reused when complete, else simulated "
      "there (default OUT/datasets)");
  cmd->add_option("--out",
                  args->out,
                  "per scene map.ply, map.png, slip_points.csv, evaluation.json; "
                  "report.json")
      ->capture_default_str();
  AddReplayOptions(cmd, args->replay);
  cmd->add_option("--coverage-distance",
                  args->evaluation.coverage_distance_mm,
                  "a touched point is covered by a known vertex this near, mm")
      ->capture_default_str();
  args->map.Add(cmd);
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    const std::string datasets = args->datasets.empty() ? args->out + "/datasets" : args->datasets;
    MakeDirectory(datasets);
    MakeDirectory(args->out);
    ReplayArgs replay = args->replay;
    replay.show_progress = true;  // on stderr
    nlohmann::json report = {{"datasets", datasets}};
    GainsFittedOnce gains(replay, datasets);
    std::vector<FrictionEvaluation> results;
    nlohmann::json scenes = nlohmann::json::array();
    for (const std::string& name : args->scenes) {
      const std::string folder = datasets + "/" + std::filesystem::path(name).stem().string();
      const double simulate_s = EnsureTwinDataset({.scene = name, .out = folder, .cache_dir = replay.cache_dir});
      const TwinDatasetReader reader(folder);
      const Scene scene = LoadSceneOrBuiltIn(reader.header().at("scene").get<std::string>());
      friction::FrictionMapBuilder builder(args->map.Options(scene.sensor));
      FrictionReplayRecorder recorder(builder);
      auto start = std::chrono::steady_clock::now();
      const ReplayRun run = gains.Replay(
          folder, report, [&](const TwinStep& s, const TactileFrame& f) { recorder.Add(s, f); });
      const double replay_s = SecondsSince(start);
      start = std::chrono::steady_clock::now();
      ProgressBar bar(scene.name + " map", 4);
      const friction::FrictionMapResult map =
          builder.Build([&](int done, int) { bar.Update(done); });
      bar.Finish();
      const double map_s = SecondsSince(start);
      const std::vector<Eigen::Vector3d> touched =
          TouchedTrueSurface(reader, scene, args->evaluation.touched_voxel_mm, replay.max_steps);
      FrictionEvaluation e =
          EvaluateFrictionMap(scene, map, recorder.truth(), touched, args->evaluation);
      e.simulate_s = simulate_s;
      e.replay_s = replay_s;
      e.map_s = map_s;
      nlohmann::json j = ToJson(e);
      j["files"] = friction::WriteFrictionMapFiles(map, args->out + "/" + scene.name, args->map.View(map));
      j["replay"] = run.report;
      j["strokes"] = recorder.strokes();
      j["map_options"] = friction::ToJson(builder.options());
      WriteTextFileAtomically(args->out + "/" + scene.name + "/evaluation.json", j.dump(2) + "\n");
      results.push_back(std::move(e));
      scenes.push_back(std::move(j));
    }
    const FrictionEvaluation overall = PoolFrictionEvaluations(results);
    report["scenes"] = scenes;
    report["overall"] = ToJson(overall);
    bool all_pass = report["overall"]["all_pass"].get<bool>();
    for (const nlohmann::json& s : scenes) all_pass = all_pass && s.at("all_pass").get<bool>();
    report["all_pass"] = all_pass;
    WriteTextFileAtomically(args->out + "/report.json", report.dump(2) + "\n");
    if (args->json) {
      std::printf("%s\n", report.dump(2).c_str());
      return;
    }
    for (const FrictionEvaluation& e : results) std::printf("%s\n", e.BriefReport().c_str());
    std::printf("%s\n", overall.BriefReport().c_str());
    PrintChecks(report["overall"]["checks"]);
    std::printf(
        "wrote %s/report.json and %s/<scene>/{map.ply,map.png,slip_points.csv,evaluation.json}\n",
        args->out.c_str(),
        args->out.c_str());
  });
}

}  // namespace tac3d::cli
