#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/util/file_io.h"
#include "model_args.h"
#include "tac3d/eval/force_evaluation.h"
#include "tac3d/force/force_gains.h"

namespace tac3d::cli {

void RegisterEvalForce(CLI::App& eval) {
  struct Args {
    ModelArgs model;
    EvalForceOptions options;
    std::string weight_rule = ToString(WeightSelectionOptions{}.rule);
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "force",
      "The inverse F = K D on displacements of a finer, independent FEM with other elastic "
      "constants: resultant error after a gain fit, probe location, two-pin resolution");
  args->model.Add(cmd);
  EvalForceOptions& o = args->options;
  cmd->add_option("--truth-refinement", o.truth_refinement,
                  "the true sensor's mesh refinement relative to the nominal one")
      ->capture_default_str();
  cmd->add_option("--truth-shear-factor", o.truth_shear_modulus_factor,
                  "the true shear modulus G / the nominal one")
      ->capture_default_str();
  cmd->add_option("--truth-bulk-factor", o.truth_bulk_modulus_factor,
                  "the true bulk modulus K / the nominal one")
      ->capture_default_str();
  cmd->add_option("--noise-mm", o.noise_mm, "displacement noise, 1 sigma (mm)")->capture_default_str();
  cmd->add_option("--calibration-presses", o.calibration_presses, "presses for w and the gains")
      ->capture_default_str();
  cmd->add_option("--test-presses", o.test_presses, "presses the resultant error is measured on")
      ->capture_default_str();
  cmd->add_option("--weight-rule", args->weight_rule, "discrepancy, gcv or given")->capture_default_str();
  cmd->add_option("--weight", o.weight.weight, "w for --weight-rule given, (mm/N)^2");
  cmd->add_flag("--no-support-refinement", [&o](std::int64_t) { o.support_refinement = false; },
                "the paper's F = K D alone, without the contact-support re-solve");
  cmd->add_option("--seed", o.seed, "random seed of the presses and the noise")->capture_default_str();
  cmd->callback([args] {
    EvalForceOptions options = args->options;
    options.body = args->model.Body();
    options.cache_dir = args->model.cache_dir;
    options.weight.rule = WeightRuleFromString(args->weight_rule);
    options.show_progress = !args->model.json;
    MakeDirectory(options.cache_dir);
    nlohmann::json j = EvaluateForce(options);
    if (args->model.json) {
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    PrintChecks(j.at("checks"));
    std::printf("resultant error, %% of full scale, max x y z: %s, rms x y z: %s\n",
                j.at("resultant_error_max_pct_fs_xyz").dump().c_str(),
                j.at("resultant_error_rms_pct_fs_xyz").dump().c_str());
    std::printf("gains: %s\nweight: %s\nall pass: %s\n", j.at("gains").dump().c_str(),
                j.at("weight").dump().c_str(), j.at("all_pass").get<bool>() ? "yes" : "no");
  });
}

void RegisterCalibrateForce(CLI::App& app) {
  struct Args {
    std::string pairs;
    std::string out;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate-force",
      "Fit the per-axis force gains Cx, Cy, Cz to a reference force sensor (docs/force.md)");
  cmd->add_option("--pairs", args->pairs,
                  "CSV of (resultant measured with unit gains, reference reading) pairs")
      ->required();
  cmd->add_option("--out", args->out, "also write the fit as JSON to this file");
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    const ForceGainFit fit = FitForceGains(LoadForcePairs(args->pairs));
    const nlohmann::json j = ToJson(fit);
    if (!args->out.empty()) WriteTextFileAtomically(args->out, j.dump(2) + "\n");
    if (args->json) {
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%d pairs\n", fit.num_pairs);
    for (int axis = 0; axis < 3; ++axis) {
      std::printf("C%c = %.5f   R^2 %.5f   residual RMS %.4f N\n", "xyz"[axis], fit.gains(axis),
                  fit.r_squared(axis), fit.residual_rms_n(axis));
    }
    std::printf("use them with: tac3d run ... --gains %.6g %.6g %.6g\n", fit.gains.x(),
                fit.gains.y(), fit.gains.z());
  });
}

}  // namespace tac3d::cli
