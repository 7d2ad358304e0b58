#pragma once

// Shared by `tac3d friction-map`, `tac3d eval friction` and the demo.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

#include "tac3d/friction/friction_map.h"
#include "tac3d/friction/friction_output.h"
#include "tac3d/friction_eval/friction_evaluation.h"
#include "twin_runs.h"

namespace tac3d::cli {

/// The friction map's options on the command line (FrictionMapOptions' fields), and the
/// PNG's view.
struct FrictionMapArgs {
  // The CLI's defaults differ from FrictionMapOptions' (the paper's equation 6) where the twin
  // evaluation showed the paper's weighting biased by the force inverse's per-marker noise
  // (docs/friction.md): beta 0 and gamma 1 (the ratio of the summed forces), 30 slip points a
  // vertex and no vertex whose slip points lie to one side (0.3 r), slips detected down to
  // 0.005 N, motion in the tangent plane, only steady gross slip votes, mu_i from the force
  // against the slip. < 0: the library's.
  double contact_threshold_n = -1;
  double slip_sigmas = -1;
  double marker_noise_mm = -1;
  double radius_mm = -1;
  double voxel_size_mm = -1;
  int poisson_depth = -1;
  double beta = 0.0;
  double gamma = 1.0;
  int min_slip_points = 30;
  double max_support_offset = 0.3;
  double slip_contact_threshold_n = 0.005;
  bool tangential_motion = true;
  bool gross_slip_only = true;
  bool friction_along_slip = true;
  int gross_slip_margin = -1;
  std::vector<double> view;  ///< empty: look at the mesh's outer side (minus its mean normal)
  std::vector<double> up;    ///< empty: world y (x if y is along the view)

  void Add(CLI::App* cmd);
  /// FromSensor's defaults with the options given.
  friction::FrictionMapOptions Options(const SensorConfig& sensor) const;
  friction::RenderOptions View(const friction::FrictionMapResult& map) const;
};

/// What a map built from a replayed twin dataset was built from, for its summary.json
/// (friction::WriteFrictionMapOutputs): the dataset, the gains it was replayed with and the
/// strokes the recorder saw.
nlohmann::json ReplayMapInputs(const ReplayRun& run, const FrictionReplayRecorder& recorder);

}  // namespace tac3d::cli
