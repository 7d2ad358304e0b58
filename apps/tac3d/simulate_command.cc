#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "twin_runs.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/simulation/simulation.h"
#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::cli {
namespace {

nlohmann::json ToJson(const TwinDeviation& d) {
  return {{"mesh_refinement", d.mesh_refinement},
          {"youngs_modulus_factor", d.youngs_modulus_factor},
          {"poisson_ratio_factor", d.poisson_ratio_factor}};
}

nlohmann::json ToJson(const SessionConditions& c) {
  return {{"session_s", c.session_s},
          {"illumination_gain", c.illumination_gain},
          {"illumination_offset", c.illumination_offset},
          {"illumination_gradient", c.illumination_gradient},
          {"contrast_fade", c.contrast_fade},
          {"exposure_drift", c.exposure_drift},
          {"creep_mm", c.creep_mm},
          {"creep_direction", {c.creep_direction.x(), c.creep_direction.y(), c.creep_direction.z()}}};
}

// The spread's tolerances and the sensor the twin renders with (what a calibration should
// recover); null without one.
nlohmann::json SpreadJson(const Scene& scene) {
  if (!scene.spread) return nullptr;
  const SensorPerturbationOptions& o = *scene.spread;
  return {{"seed", o.seed},
          {"mirror_tilt_max_deg", o.mirror_tilt_max_deg},
          {"mirror_shift_max_mm", o.mirror_shift_max_mm},
          {"camera_tilt_max_deg", o.camera_tilt_max_deg},
          {"camera_shift_max_mm", o.camera_shift_max_mm},
          {"true_sensor_yaml", SensorConfigToYaml(PerturbSensor(scene.sensor, o))}};
}

}  // namespace

SimulateRun SimulateToDataset(const SimulateArgs& args) {
  if (args.steps < 0) throw Error(fmt::format("--steps must be >= 0, got {}", args.steps));
  Scene scene = LoadSceneOrBuiltIn(args.scene);
  if (args.twin_refinement) {
    RequireTwinRefinement(*args.twin_refinement);
    scene.deviation.mesh_refinement = *args.twin_refinement;
  }
  const fem::BodyModelOptions body = simulation::TwinBodyModelOptions(scene.sensor, scene.deviation);
  // The output folder first, so a bad --out fails before a long model build.
  TwinDatasetWriter writer(
      args.out, {{"name", scene.name},
                 {"scene", args.scene},
                 {"deviation", ToJson(scene.deviation)},
                 {"conditions", ToJson(scene.conditions)},
                 {"spread", SpreadJson(scene)}});
  MakeCacheDirectory(args.cache_dir);
  simulation::TwinBodyCacheResult cached = simulation::LoadOrBuildTwinBodyModel(
      body, simulation::TwinBodyOptions{}, args.cache_dir, /*show_progress=*/true);
  std::fprintf(stderr, "twin body %s in %.1f s: %s\n", Describe(cached.status), cached.elapsed_s,
               cached.path.c_str());
  if (!cached.reason.empty()) std::fprintf(stderr, "why not the cached file: %s\n", cached.reason.c_str());
  const auto model = std::make_shared<const simulation::TwinBodyModel>(std::move(cached.model));

  simulation::SimulationOptions options;
  options.render_images = !args.no_images;
  options.max_steps = args.steps;
  options.contact.windowed = !args.no_window;
  options.show_progress = true;
  simulation::TwinSimulation sim(scene, model, options);
  const contact::KernelSymbolReport& symbol = sim.compliance().symbol_report();
  SimulateRun run;
  run.model = {{"cache_file", cached.path},
               {"cache_status", Describe(cached.status)},
               {"load_or_build_s", cached.elapsed_s},
               {"body", fem::ToJson(model->body)},
               {"options", simulation::ToJson(model->options)},
               {"grid", simulation::ToJson(model->grid)},
               {"symbol",
                {{"min_eigenvalue", symbol.min_eigenvalue},
                 {"max_eigenvalue", symbol.max_eigenvalue},
                 {"num_clamped", symbol.num_clamped},
                 {"num_frequencies", symbol.num_frequencies}}},
               {"provenance", simulation::ToJson(model->provenance)}};
  writer.UpdateHeader({{"steps", sim.num_steps()}, {"twin_body", run.model}});
  run.summary = sim.Run([&writer](const TwinStep& step) { writer.Write(step); });
  writer.UpdateHeader({{"summary", simulation::ToJson(run.summary)}});
  return run;
}

double EnsureTwinDataset(const SimulateArgs& args) {
  if (std::filesystem::exists(args.out + "/dataset.json")) {
    const TwinDatasetReader reader(args.out);
    const nlohmann::json& h = reader.header();
    if (!h.contains("summary")) {
      throw Error(fmt::format("{}: the simulation did not finish (no summary in dataset.json); remove the "
                              "folder to simulate it again",
                              args.out));
    }
    const double refinement = h.at("deviation").at("mesh_refinement").get<double>();
    if (args.twin_refinement && refinement != *args.twin_refinement) {
      throw Error(fmt::format("{}: simulated at twin refinement {}, not {}; remove the folder or give "
                              "another datasets folder",
                              args.out, refinement, *args.twin_refinement));
    }
    std::fprintf(stderr, "reusing %s\n", args.out.c_str());
    return h.at("summary").at("timings_s").value("total", 0.0);
  }
  const auto start = std::chrono::steady_clock::now();
  SimulateToDataset(args);
  return SecondsSince(start);
}

void RequireTwinRefinement(double refinement) {
  if (!(refinement >= 1.0 && refinement <= 4.0)) {  // TwinDeviation's bounds (Scene::Validate)
    throw Error(fmt::format("--twin-refinement must be in [1, 4], got {}", refinement));
  }
}

void AddTwinRefinementOption(CLI::App* cmd, std::optional<double>* refinement) {
  cmd->add_option("--twin-refinement", *refinement,
                  "the twin's FEM refinement (pipeline's edges / this, in [1, 4]) instead of the "
                  "scene's; peak memory of the twin body's build: ~3 GB at 1.25, ~6.7 GB at 1.5");
}

void RegisterSimulate(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate", "Run the digital twin's frictional contact along a scene; write a dataset");
  cmd->add_option("--scene", args->scene, "scene YAML file or built-in name")->required();
  cmd->add_option("--out", args->out, "dataset folder to create (must be new or empty)")
      ->required();
  cmd->add_option("--cache,--cache-dir", args->cache_dir, "directory of cached twin body models")
      ->capture_default_str();
  cmd->add_flag("--no-images", args->no_images, "do not render camera images");
  cmd->add_option("--steps", args->steps, "simulate only the first N steps (0: all)")
      ->capture_default_str();
  AddTwinRefinementOption(cmd, &args->twin_refinement);
  cmd->add_flag("--no-window", args->no_window,
                "solve each contact on the whole grid, not on a window around it (the same "
                "solution, slower; docs/contact.md)");
  cmd->add_flag("--json", args->json, "print the summary as JSON");
  cmd->callback([args] {
    const SimulateRun run = SimulateToDataset(*args);
    const simulation::SimulationSummary& summary = run.summary;
    const nlohmann::json& model_json = run.model;
    const nlohmann::json summary_json = simulation::ToJson(summary);
    if (args->json) {
      std::printf("%s\n",
                  nlohmann::json{
                      {"dataset", args->out}, {"twin_body", model_json}, {"summary", summary_json}}
                      .dump(2)
                      .c_str());
      return;
    }
    const nlohmann::json& ms = summary_json.at("per_step_ms");
    std::printf("%d steps (%d in contact) -> %s\n",
                summary.steps,
                summary.contact_steps,
                args->out.c_str());
    std::printf(
        "contact solver: %d not converged; max iterations normal %d, tangential %d, "
        "coupling %d; max penetration %.3g mm, max cone violation %.3g MPa\n",
        summary.non_converged_steps,
        summary.max_normal_iterations,
        summary.max_tangential_iterations,
        summary.max_coupling_iterations,
        summary.max_penetration_mm,
        summary.max_cone_violation_mpa);
    if (summary.contact_at_grid_edge_steps > 0) {
      std::printf("warning: %d steps touch the contact grid's edge\n",
                  summary.contact_at_grid_edge_steps);
    }
    std::printf(
        "time %.1f s: per step %.1f ms (gap %.1f, contact %.1f, response %.1f, render "
        "%.1f, write %.1f)\n",
        summary.timings.total_s,
        ms.at("total").get<double>(),
        ms.at("gap").get<double>(),
        ms.at("contact").get<double>(),
        ms.at("response").get<double>(),
        ms.at("render").get<double>(),
        ms.at("write").get<double>());
  });
}

}  // namespace tac3d::cli
