#pragma once

#include <array>

#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// How faithful the twin's camera is, measured on its own renders of the undeformed marker
/// layer (`tac3d eval render`).
struct RenderEvaluation {
  /// Dark blobs found by plain OpenCV blob detection in each image half (noise on).
  std::array<int, 2> blobs_per_half = {0, 0};
  /// Darkness-weighted centroid of each dot's image (8-bit, blur, no noise, no vignetting)
  /// against the exact ray-traced projection of its centre, over every dot in both halves.
  int dots_measured = 0;
  double centroid_error_median_px = 0.0;
  double centroid_error_max_px = 0.0;
  /// Median wall time of one 640x480 render (ms) over `timing_frames` frames.
  double render_median_ms = 0.0;
};

RenderEvaluation EvaluateRender(const SensorConfig& config, int timing_frames = 20);

}  // namespace tac3d
