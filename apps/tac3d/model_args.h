#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "commands.h"
#include "tac3d/fem/body_model.h"
#include "tac3d/vendor_formats/vendor_gel.h"

namespace tac3d::cli {

/// The options of every command that works on the sensor's FEM model: the sensor, the model
/// cache, the mesh refinement, JSON output.
struct ModelArgs {
  std::string config;
  std::string cache_dir = DefaultCacheDir();
  double refinement = 1.0;
  bool json = false;

  void Add(CLI::App* cmd) {
    cmd->add_option("--config", config, "sensor YAML (default: the built-in prototype)");
    cmd->add_option("--cache,--cache-dir", cache_dir, "directory of cached compliance models")
        ->capture_default_str();
    cmd->add_option("--refinement", refinement, "mesh refinement (1 = the paper's mesh)")
        ->capture_default_str();
    cmd->add_flag("--json", json, "print JSON");
  }
  fem::BodyModelOptions Body() const {
    fem::BodyModelOptions body = SensorBodyModelOptions(LoadSensorOrDefault(config));
    body.refinement = refinement;
    return body;
  }
};

}  // namespace tac3d::cli
