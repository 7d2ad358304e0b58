#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "model_args.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/fem/evaluation.h"

namespace tac3d::cli {

void RegisterBuildModel(CLI::App& app) {
  auto args = std::make_shared<ModelArgs>();
  CLI::App* cmd = app.add_subcommand(
      "build-model", "Build the FEM compliance matrix H of the sensor's elastic body (cached)");
  args->Add(cmd);
  cmd->callback([args] {
    const fem::BodyModelOptions body = args->Body();
    MakeCacheDirectory(args->cache_dir);
    const fem::ComplianceCacheResult r =
        fem::LoadOrBuildComplianceModel(body, args->cache_dir, /*show_progress=*/ShowProgress(args->json));
    const nlohmann::json provenance = fem::ToJson(r.model.provenance);
    if (args->json) {
      const nlohmann::json j = {{"path", r.path},
                                {"status", Describe(r.status)},
                                {"reason", r.reason},
                                {"elapsed_s", r.elapsed_s},
                                {"markers", r.model.marker_positions.size()},
                                {"options", fem::ToJson(body)},
                                {"provenance", provenance}};
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("H (%ld x %ld) %s in %.2f s: %s\n", static_cast<long>(r.model.h.rows()),
                static_cast<long>(r.model.h.cols()), Describe(r.status), r.elapsed_s, r.path.c_str());
    if (!r.reason.empty()) std::printf("why not the cached file: %s\n", r.reason.c_str());
    std::printf("provenance: %s\n", provenance.dump().c_str());
  });
}

void RegisterEvalFem(CLI::App& eval) {
  auto args = std::make_shared<ModelArgs>();
  auto convergence = std::make_shared<double>(fem::EvalFemOptions{}.convergence_refinement);
  CLI::App* cmd = eval.add_subcommand(
      "fem", "FEM against analytic oracles: patch test, confined block, Boussinesq, Cerruti, refinement");
  args->Add(cmd);
  cmd->add_option("--convergence-refinement", *convergence,
                  "refinement of the mesh-convergence check (0 skips it)")
      ->capture_default_str();
  cmd->callback([args, convergence] {
    fem::EvalFemOptions options;
    options.body = args->Body();
    options.cache_dir = args->cache_dir;
    options.convergence_refinement = *convergence;
    options.show_progress = ShowProgress(args->json);
    MakeCacheDirectory(options.cache_dir);
    const fem::EvalFemResult result = fem::EvaluateFem(options);
    if (args->json) {
      std::printf("%s\n", ToJson(result).dump(2).c_str());
      return;
    }
    std::printf("%s", result.Report().c_str());
  });
}

}  // namespace tac3d::cli
