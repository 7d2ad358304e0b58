#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "tac3d/eval/replay_evaluation.h"
#include "tac3d/simulation/simulation.h"

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
void RegisterFrictionMap(CLI::App& app);

/// `tac3d eval <what>`: accuracy evaluations against the twin's truth or analytic oracles,
/// each printing its figures (JSON with --json). Each adds itself to the `eval` group.
void RegisterEval(CLI::App& app);
void RegisterEvalRender(CLI::App& eval);
void RegisterEvalCalibration(CLI::App& eval);
void RegisterEvalFem(CLI::App& eval);
void RegisterEvalContact(CLI::App& eval);
void RegisterEvalForce(CLI::App& eval);
void RegisterEvalReplay(CLI::App& eval);
void RegisterEvalFriction(CLI::App& eval);


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

/// A twin simulation as `tac3d simulate` and the demo run it.
struct SimulateArgs {
  std::string scene;
  std::string out;
  std::string cache_dir = DefaultCacheDir();
  bool no_images = false;
  int steps = 0;
  bool json = false;
};

struct SimulateRun {
  simulation::SimulationSummary summary;
  nlohmann::json model;  ///< the twin body: cache file and status, body, grid, symbol
};

/// Loads the scene (a file or a built-in name) and the twin body (from the cache, or built),
/// simulates it with progress bars and writes the dataset to args.out.
/// @throws Error on a bad scene, a non-empty output folder or a failed write.
SimulateRun SimulateToDataset(const SimulateArgs& args);

/// A replay evaluation as `tac3d eval replay` and the demo run it.
struct ReplayArgs {
  std::string dataset;
  std::string calibration;     ///< a calibration dataset to fit the gains on, or ""
  std::vector<double> gains;   ///< Cx Cy Cz when given, else unit gains or the fitted ones
  std::string config;          ///< sensor YAML, or "" for the dataset's scene's sensor
  std::string cache_dir = DefaultCacheDir();
  int max_steps = 0;
  int max_support_markers = 0;  ///< ForceReconstructorOptions::max_support_markers; 0: default
  bool show_progress = true;
};

struct ReplayRun {
  ReplayOptions options;  ///< as run, the gains included
  std::optional<ReplayGainCalibration> calibration;
  ReplayResult replay;
  nlohmann::json report;  ///< the summary (ToJson), the calibration's fit and summary
};

/// Loads the sensor and the nominal compliance (from the cache), fits the gains on the
/// calibration dataset if one is given, and replays the dataset.
/// @throws Error on bad arguments or datasets (ReplayTwinDataset, FitForceGains).
ReplayRun RunReplay(const ReplayArgs& args,
                    const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame = {});

/// Writes report.json, frames.csv (per-frame measured vs true) and force_pairs.csv (the
/// calibration's pairs if gains were fitted, else the dataset's own: `tac3d calibrate-force
/// --pairs` reproduces the gains from it) into `folder`. @throws Error if a file cannot be written.
void WriteReplayFiles(const ReplayRun& run, const std::string& folder);

/// Writes text to a file. @throws Error naming the file if it cannot.
void WriteTextFile(const std::string& path, const std::string& text);

/// Prints an evaluation's checks ([{name, value, unit, tolerance, pass}]), one line each.
void PrintChecks(const nlohmann::json& checks);

}  // namespace tac3d::cli
