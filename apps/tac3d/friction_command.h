#pragma once

// Shared by `tac3d friction-map` and `tac3d eval friction`.
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "tac3d/friction/friction_map.h"
#include "tac3d/friction/friction_output.h"

namespace tac3d::cli {

/// The friction map's options on the command line (FrictionMapOptions' fields), and the
/// PNG's view.
struct FrictionMapArgs {
  double contact_threshold_n = -1;  ///< < 0: the default
  double slip_sigmas = -1;
  double marker_noise_mm = -1;
  double radius_mm = -1;
  double voxel_size_mm = -1;
  int poisson_depth = -1;
  double beta = -1;
  std::vector<double> view;  ///< empty: look at the mesh's outer side (minus its mean normal)
  std::vector<double> up;    ///< empty: world y (x if y is along the view)

  void Add(CLI::App* cmd);
  /// FromSensor's defaults with the options given.
  friction::FrictionMapOptions Options(const SensorConfig& sensor) const;
  friction::RenderOptions View(const friction::FrictionMapResult& map) const;
};

/// Writes map.ply, slip_points.csv, map.png (bands, the view) into `folder` and returns what
/// was written (files, the render's band pixels) as JSON.
nlohmann::json WriteFrictionMapFiles(const friction::FrictionMapResult& map, const std::string& folder,
                                     const friction::RenderOptions& view);

}  // namespace tac3d::cli
