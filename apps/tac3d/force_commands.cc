#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "model_args.h"
#include "tac3d/eval/force_evaluation.h"
#include "tac3d/eval/vendor_evaluation.h"
#include "tac3d/fem/compliance_family.h"
#include "tac3d/force/force_gains.h"
#include "tac3d/material_calibration/material_calibration.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::cli {

void RegisterEvalForce(CLI::App& eval) {
  struct Args {
    ModelArgs model;
    EvalForceOptions options;
    std::string weight_rule = ToString(WeightSelectionOptions{}.rule);
    std::vector<double> truth_material;
    bool material_grid = false;
    MaterialGrid grid;
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
  cmd->add_option("--truth-material",
                  args->truth_material,
                  "the true E (MPa) and nu, instead of the shear and bulk factors")
      ->expected(2);
  cmd->add_flag("--material-grid",
                args->material_grid,
                "evaluate at every true material of the grid below instead of one (one true "
                "model a Poisson's ratio)");
  cmd->add_option("--grid-youngs-factors",
                  args->grid.youngs_modulus_factors,
                  "the grid's true E as multiples of the nominal E")
      ->capture_default_str();
  cmd->add_option("--grid-poisson", args->grid.poisson_ratios, "the grid's true nu")
      ->capture_default_str();
  cmd->add_flag("--calibrate-material",
                o.calibrate_material,
                "fit E and nu as well as the gains on the calibration presses (docs/force.md)");
  cmd->add_flag("--with-contact-centers",
                o.material_contact_centers,
                "with --calibrate-material: the presses' centres join the fit");
  cmd->add_option("--location-weight",
                  o.material.location_weight_n_per_mm,
                  "with --with-contact-centers: N of resultant error a 1 mm centre error weighs")
      ->capture_default_str();
  cmd->add_option("--poisson-nodes",
                  o.poisson_nodes,
                  "nu at which H is built for --calibrate-material (interpolated between)")
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
    if (!args->truth_material.empty()) {
      if (args->material_grid) throw Error("--truth-material and --material-grid exclude each other");
      options.SetTrueMaterial({args->truth_material[0], args->truth_material[1]});
    }
    options.show_progress = ShowProgress(args->model.json);
    MakeCacheDirectory(options.cache_dir);
    if (args->material_grid) {
      // A line a point as it is done (JSON with --json): a later solve failing loses none.
      const bool json = args->model.json;
      const std::vector<ForceEvaluation> points =
          EvaluateForceOverMaterials(options, args->grid, [json](const ForceEvaluation& point) {
            if (json) {
              WriteLineFlushed(stdout, ToJson(point).dump());
            } else {
              WriteLineFlushed(stdout, point.GridLine());
            }
          });
      if (!json) {
        const bool all_pass = std::all_of(points.begin(), points.end(),
                                          [](const ForceEvaluation& p) { return p.all_pass; });
        std::printf("all pass: %s\n", all_pass ? "yes" : "no");
      }
      return;
    }
    const ForceEvaluation evaluation = EvaluateForce(options);
    if (args->model.json) {
      std::printf("%s\n", ToJson(evaluation).dump(2).c_str());
    } else {
      std::printf("%s", evaluation.Report().c_str());
    }
  });
}

namespace {

void PrintGains(const ForceGainFit& fit) {
  std::printf("%d pairs\n", fit.num_pairs);
  for (int axis = 0; axis < 3; ++axis) {
    std::printf("C%c = %.5f   R^2 %.5f   residual RMS %.4f N\n",
                "xyz"[axis],
                fit.gains(axis),
                fit.r_squared(axis),
                fit.residual_rms_n(axis));
  }
  std::printf("use them with: tac3d run ... --gains %.6g %.6g %.6g\n",
              fit.gains.x(),
              fit.gains.y(),
              fit.gains.z());
}

struct CalibrateForceArgs {
  std::string pairs;
  std::string presses;
  std::string vendor_recording;
  double min_resultant_n = VendorForceOptions{}.min_resultant_n;
  ModelArgs model;
  std::vector<double> poisson_nodes = EvalForceOptions{}.poisson_nodes;
  double noise_mm = 0.0;
  double weight = 0.0;
  MaterialCalibrationOptions material;
  std::string out;
};

// Fits E and nu, then the gains, on the presses. Every input (the presses, the options, the
// output path) is read and checked before the compliance family's FEM solves start.
nlohmann::json CalibrateOnPresses(const CalibrateForceArgs& args) {
  const fem::BodyModelOptions body = args.model.Body();
  MaterialCalibrationOptions options = args.material;
  DisplacementNoise noise;
  if (args.weight > 0.0) {
    options.weight = {.rule = WeightRule::kGiven, .weight = args.weight};
  } else if (args.noise_mm > 0.0) {
    noise.variance_mm2.setConstant(args.noise_mm * args.noise_mm);
  } else {
    throw Error(
        "calibrate-force --presses needs --noise-mm (for the discrepancy principle) or "
        "--weight");
  }
  options.Validate();
  const std::vector<CalibrationPress> presses =
      LoadCalibrationPresses(args.presses, body.num_markers());
  MakeCacheDirectory(args.model.cache_dir);
  const fem::ComplianceFamily family(
      body, args.poisson_nodes, args.model.cache_dir, !args.model.json);
  const MaterialCalibration fit = CalibrateMaterial(family, presses, noise, options);
  if (!args.model.json) {
    std::printf("%s\nresidual with the material alone: %.4f N RMS; weight %.4g (mm/N)^2\n",
                fit.message.c_str(),
                fit.residual_rms_n,
                fit.weight);
    PrintGains(fit.gains);
    std::printf("with E and nu in the sensor config's elastic body, and --weight %.6g\n",
                fit.weight);
  }
  return ToJson(fit);
}

// --vendor-recording: the gains that make tac3d's resultant the vendor's, on the axes the
// recording determines.
nlohmann::json CalibrateOnVendorRecording(const CalibrateForceArgs& args) {
  if (args.model.config.empty()) {
    throw Error("calibrate-force --vendor-recording needs the sensor's --config (`tac3d import-vendor`)");
  }
  const SensorConfig config = LoadSensorConfig(args.model.config);
  if (!config.vendor_camera) {
    throw Error(fmt::format("--config '{}' has no vendor camera model: --vendor-recording adopts an imported "
                            "sensor's factory calibration (`tac3d import-vendor`)",
                            args.model.config));
  }
  const VendorRecording recording = ReadVendorRecording(args.vendor_recording);
  if (recording.serial_number != config.vendor_camera->serial_number) {
    throw Error(fmt::format("the recording is of sensor '{}', the config of sensor '{}'", recording.serial_number,
                            config.vendor_camera->serial_number));
  }
  MakeCacheDirectory(args.model.cache_dir);
  VendorForceOptions options = {.min_resultant_n = args.min_resultant_n, .cache_dir = args.model.cache_dir,
                                .show_progress = !args.model.json};
  options.gel.refinement = args.model.refinement;
  const VendorGainCalibration c =
      CalibrateGainsOnVendorRecording(config, recording, options, args.material.gain_fit);
  if (!args.model.json) {
    std::printf("%d frames of %s with the recorded |resultant| over %g N; inverse: weight %g (mm/N)^2, "
                "contact-support re-solve %s\n",
                c.frames_compared, recording.serial_number.c_str(), args.min_resultant_n, c.inverse.weight,
                c.inverse.support_refinement ? "on" : "off");
    PrintGains(c.fit);
    for (int axis = 0; axis < 3; ++axis) {
      if (!c.fit.left_at_one[axis].empty()) {
        std::printf("C%c left at 1: %s\n", "xyz"[axis], c.fit.left_at_one[axis].c_str());
      }
    }
  }
  nlohmann::json j = ToJson(c.fit);
  j["frames_compared"] = c.frames_compared;
  j["frames_not_finite"] = c.frames_not_finite;
  j["inverse"] = {{"weight", c.inverse.weight}, {"support_resolve", c.inverse.support_refinement}};
  return j;
}

}  // namespace

void RegisterCalibrateForce(CLI::App& app) {
  auto args = std::make_shared<CalibrateForceArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate-force",
      "Fit the per-axis force gains Cx, Cy, Cz to a reference force sensor (or with --vendor-recording to "
      "the vendor's recorded resultant), and with --presses "
      "the silicone's E and nu first (docs/force.md)");
  CLI::Option* pairs =
      cmd->add_option("--pairs",
                      args->pairs,
                      "CSV of (resultant measured with unit gains, reference reading) pairs");
  CLI::Option* presses = cmd->add_option(
      "--presses",
      args->presses,
      "CSV of presses (reference reading, marker displacements): fit E and nu, then the gains");
  CLI::Option* vendor = cmd->add_option(
      "--vendor-recording", args->vendor_recording,
      "a recording of the vendor's software (its <SN> folder or the folder holding it), with --config the "
      "sensor's imported YAML: fit the gains that make tac3d's resultant the recorded one, on the axes "
      "the recording determines (the others are left at 1)");
  cmd->add_option("--min-resultant-n", args->min_resultant_n,
                  "with --vendor-recording: the frames whose recorded |resultant| exceeds this (N)")
      ->capture_default_str();
  pairs->excludes(presses);
  vendor->excludes(pairs);
  vendor->excludes(presses);
  cmd->add_option("--poisson-nodes",
                  args->poisson_nodes,
                  "with --presses: nu at which H is built (cached), interpolated between")
      ->capture_default_str();
  cmd->add_option(
      "--noise-mm",
      args->noise_mm,
      "with --presses: displacement noise, 1 sigma (mm), for the discrepancy principle");
  cmd->add_option("--weight", args->weight, "with --presses: a given w instead, (mm/N)^2");
  cmd->add_option("--location-weight",
                  args->material.location_weight_n_per_mm,
                  "with --presses carrying centres (cx_mm, cy_mm): N of resultant error a 1 mm "
                  "centre error weighs (0 ignores them)")
      ->capture_default_str();
  cmd->add_option("--max-poisson-error",
                  args->material.max_poisson_error,
                  "with --presses: refuse the fit if nu is less certain than this")
      ->capture_default_str();
  cmd->add_option("--min-r-squared", args->material.gain_fit.min_r_squared,
                  "refuse the gains if an axis' R^2 is below this (a fit to noise)")
      ->capture_default_str();
  args->model.Add(cmd);
  cmd->add_option("--out", args->out, "also write the fit as JSON to this file");
  cmd->callback([args] {
    if (!args->out.empty()) {
      CheckOutputFile(args->out, "--out", {}, {args->pairs, args->presses, args->vendor_recording, args->model.config});
    }
    nlohmann::json j;
    if (!args->pairs.empty()) {
      args->material.gain_fit.Validate();  // before the file is read
      const ForceGainFit fit = FitForceGains(LoadForcePairs(args->pairs), args->material.gain_fit);
      j = ToJson(fit);
      if (!args->model.json) PrintGains(fit);
    } else if (!args->presses.empty()) {
      j = CalibrateOnPresses(*args);
    } else if (!args->vendor_recording.empty()) {
      j = CalibrateOnVendorRecording(*args);
    } else {
      throw Error("calibrate-force needs --pairs, --presses or --vendor-recording");
    }
    if (!args->out.empty()) WriteTextFileAtomically(args->out, j.dump(2) + "\n");
    if (args->model.json) std::printf("%s\n", j.dump(2).c_str());
  });
}

}  // namespace tac3d::cli
