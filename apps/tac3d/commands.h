#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "tac3d/fem/body_model.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d::cli {

/// Each subcommand adds itself to the app; its callback does the work and may throw
/// tac3d::Error, which main() reports as a one-line error and exit code 1.
void RegisterDesign(CLI::App& app);
void RegisterRender(CLI::App& app);
void RegisterCalibrate(CLI::App& app);
void RegisterDemo(CLI::App& app);
void RegisterBuildModel(CLI::App& app);
void RegisterRun(CLI::App& app);
void RegisterSimulate(CLI::App& app);
void RegisterCalibrateForce(CLI::App& app);

/// `tac3d eval <what>`: accuracy evaluations against the twin's truth or analytic oracles,
/// each printing its figures (JSON with --json). Each adds itself to the `eval` group.
void RegisterEval(CLI::App& app);
void RegisterEvalRender(CLI::App& eval);
void RegisterEvalCalibration(CLI::App& eval);
void RegisterEvalFem(CLI::App& eval);
void RegisterEvalContact(CLI::App& eval);
void RegisterEvalForce(CLI::App& eval);

/// The sensor a command works on: the YAML file if one is given, else the built-in
/// prototype with its designed mirrors.
SensorConfig LoadSensorOrDefault(const std::string& path);

/// Where compliance models are cached unless --cache says otherwise: $TAC3D_CACHE_DIR, else
/// $XDG_CACHE_HOME/tac3d, else $HOME/.cache/tac3d, else .tac3d-cache.
std::string DefaultCacheDir();

/// Creates a directory (and its parents). @throws Error if it cannot.
void MakeDirectory(const std::string& path);

/// The options of every command that works on the sensor's FEM model: the sensor, the model
/// cache, the mesh refinement, JSON output.
struct ModelArgs {
  std::string config;
  std::string cache_dir = DefaultCacheDir();
  double refinement = 1.0;
  bool json = false;

  void Add(CLI::App* cmd) {
    cmd->add_option("--config", config, "sensor YAML (default: the built-in prototype)");
    cmd->add_option("--cache", cache_dir, "directory of cached compliance models")->capture_default_str();
    cmd->add_option("--refinement", refinement, "mesh refinement (1 = the paper's mesh)")
        ->capture_default_str();
    cmd->add_flag("--json", json, "print JSON");
  }
  fem::BodyModelOptions Body() const {
    fem::BodyModelOptions body = fem::BodyModelOptionsFromSensor(LoadSensorOrDefault(config));
    body.refinement = refinement;
    return body;
  }
};

}  // namespace tac3d::cli
