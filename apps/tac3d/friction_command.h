#pragma once

// Shared by `tac3d friction-map` and `tac3d eval friction`.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

#include "tac3d/friction/command_options.h"
#include "tac3d/friction/friction_map.h"
#include "tac3d/friction/friction_output.h"

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

/// The options a map was built with, for its summary.
nlohmann::json MapOptionsJson(const friction::FrictionMapOptions& o);

/// Writes map.ply, slip_points.csv, map.png (bands, the view) into `folder` and returns what
/// was written (files, the render's band pixels) as JSON.
nlohmann::json WriteFrictionMapFiles(const friction::FrictionMapResult& map,
                                     const std::string& folder,
                                     const friction::RenderOptions& view);

}  // namespace tac3d::cli
