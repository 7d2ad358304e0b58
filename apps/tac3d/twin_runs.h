#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "tac3d/eval/replay_evaluation.h"
#include "tac3d/simulation/simulation.h"

namespace tac3d::cli {

/// A twin simulation as `tac3d simulate` and the demo run it.
struct SimulateArgs {
  std::string scene;
  std::string out;
  std::string cache_dir = DefaultCacheDir();
  bool no_images = false;
  int steps = 0;
  /// The twin's FEM refinement instead of the scene's deviation.mesh_refinement (unset: the
  /// scene's). Memory grows steeply with it: 1.25 builds the default dome's twin body in
  /// ~3 GB, the scenes' 1.5 in ~6.7 GB (docs/simulation.md).
  std::optional<double> twin_refinement = std::nullopt;
  /// Solve each contact on the whole grid, not on a window around it
  /// (contact::ContactSolverOptions::windowed): the same solution, to time the two.
  bool no_window = false;
  bool json = false;
};

struct SimulateRun {
  simulation::SimulationSummary summary;
  nlohmann::json model;  ///< the twin body: cache file and status, body, grid, symbol
};

/// The dataset args.out of args.scene: reused if it is complete (its dataset.json has the
/// run's summary; "reusing FOLDER" on stderr), else simulated there. Returns the simulation's
/// time (the header's, when reused).
/// @throws Error if the folder holds an unfinished simulation, or one at another refinement
///   than args.twin_refinement, and as SimulateToDataset does.
double EnsureTwinDataset(const SimulateArgs& args);

/// @throws Error unless `refinement` is in [1, 4] (the scenes' deviation.mesh_refinement).
void RequireTwinRefinement(double refinement);

/// `--twin-refinement R` into `refinement` (SimulateArgs::twin_refinement).
void AddTwinRefinementOption(CLI::App* cmd, std::optional<double>* refinement);

/// Loads the scene (a file or a built-in name) and the twin body (from the cache, or built),
/// simulates it with progress bars and writes the dataset to args.out.
/// @throws Error on a bad scene, a non-empty output folder or a failed write.
SimulateRun SimulateToDataset(const SimulateArgs& args);

/// A replay evaluation as `tac3d eval replay` and the demo run it.
struct ReplayArgs {
  std::string dataset;
  std::string calibration;    ///< a calibration dataset to fit the gains on, or ""
  std::vector<double> gains;  ///< Cx Cy Cz when given, else unit gains or the fitted ones
  std::string config;         ///< sensor YAML, or "" for the dataset's scene's sensor
  std::string cache_dir = DefaultCacheDir();
  int max_steps = 0;
  int max_support_markers = 0;  ///< ForceReconstructorOptions::max_support_markers; 0: default
  bool show_progress = true;
  /// With `calibration`: the gain fit's R^2 floor (--min-r-squared) and what a fit under it
  /// does: refused (the default: the gains feed the command's product), or flagged by the
  /// commands that report the fit (eval replay, the demo).
  ForceGainFitOptions gain_fit;
};

/// Adds the options every command that replays twin datasets takes, into `replay`: --gains,
/// --calibration, --min-r-squared, --config, --cache, --steps (the dataset is each command's own).
void AddReplayOptions(CLI::App* cmd, ReplayArgs& replay);

/// What a replay runs on: the sensor, the nominal compliance, and the options with the gains
/// (given, or fitted on the calibration dataset).
struct ReplaySetup {
  SensorConfig config;
  Eigen::MatrixXd h;
  std::vector<Eigen::Vector3d> fem_markers_mm;
  ReplayOptions options;
  std::optional<ReplayGainCalibration> calibration;
};

/// Loads the sensor (`--config`, else the dataset's) and the nominal compliance (from the
/// cache), and fits the gains on the calibration dataset if one is given.
/// @throws Error on bad arguments or datasets (FitForceGains).
ReplaySetup PrepareReplay(const ReplayArgs& args, const TwinDatasetReader& dataset);

struct ReplayRun {
  ReplayOptions options;  ///< as run, the gains included
  std::optional<ReplayGainCalibration> calibration;
  ReplayResult replay;
  /// The summary (ToJson), the calibration's fit and summary; with a calibration, its check
  /// gain_fit_r_squared_min (the fit's lowest R^2 against its floor) joins the checks.
  nlohmann::json report;
};

/// Loads the sensor and the nominal compliance (from the cache), fits the gains on the
/// calibration dataset if one is given, and replays the dataset.
/// @throws Error on bad arguments or datasets (ReplayTwinDataset, FitForceGains).
ReplayRun RunReplay(const ReplayArgs& args,
                    const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame = {});

/// The replays of a run over several datasets (`tac3d eval friction`, `tac3d eval incipient`)
/// with their gains fitted once: without gains or a calibration given, the calibration is
/// DATASETS/force_calibration, simulated there if missing; the first replay fits the gains on
/// it and the others reuse them.
class GainsFittedOnce {
 public:
  /// Defaults the calibration and simulates it (EnsureTwinDataset in replay.cache_dir, at
  /// `twin_refinement`, unset: the scene's) if needed.
  /// @throws Error as EnsureTwinDataset.
  GainsFittedOnce(const ReplayArgs& replay,
                  const std::string& datasets,
                  std::optional<double> twin_refinement = std::nullopt);

  /// RunReplay of `dataset` with the gains given or fitted (fitted now if not yet); writes
  /// into `report` the fit's "calibration" when fitted now and "gains" as used (1 1 1 when
  /// none were given or fitted). @throws Error as RunReplay.
  ReplayRun Replay(const std::string& dataset,
                   nlohmann::json& report,
                   const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame = {});

 private:
  ReplayArgs replay_;
};

/// Writes report.json, frames.csv (per-frame measured vs true) and force_pairs.csv (the
/// calibration's pairs if gains were fitted, else the dataset's own: `tac3d calibrate-force
/// --pairs` reproduces the gains from it) into `folder`. @throws Error if a file cannot be written.
void WriteReplayFiles(const ReplayRun& run, const std::string& folder);

}  // namespace tac3d::cli
