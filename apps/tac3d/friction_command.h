#pragma once

// Shared by `tac3d friction-map`, `tac3d eval friction` and the demo.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

#include "tac3d/friction/command_options.h"
#include "tac3d/friction/friction_map.h"
#include "tac3d/friction/friction_output.h"
#include "tac3d/friction_eval/friction_evaluation.h"
#include "twin_runs.h"

namespace tac3d::cli {

/// The friction map's options on the command line (friction::FrictionMapCommandOptions(),
/// which Python's tac3d.friction_map takes too, with the same defaults), and the PNG's view.
struct FrictionMapArgs {
  friction::FrictionMapOptions options = friction::CommandFrictionMapDefaults();
  std::vector<double> view;  ///< empty: look at the mesh's outer side (minus its mean normal)
  std::vector<double> up;    ///< empty: world y (x if y is along the view)

  void Add(CLI::App* cmd);
  /// The options given, with the sensor's cover thickness. @throws Error if one is out of range.
  friction::FrictionMapOptions Options(const SensorConfig& sensor) const;
  friction::RenderOptions View(const friction::FrictionMapResult& map) const;
};

/// What a map built from a replayed twin dataset was built from, for its summary.json
/// (friction::WriteFrictionMapOutputs): the dataset, the gains it was replayed with and the
/// strokes the recorder saw.
nlohmann::json ReplayMapInputs(const ReplayRun& run, const FrictionReplayRecorder& recorder);

}  // namespace tac3d::cli
