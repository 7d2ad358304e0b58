#pragma once

// Test-only: the built-in sensor's camera image, rendered by the twin (not part of the library).

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/sensor/test_sensor.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d::testing {

/// The built-in sensor's marker image renderer, made once per test program.
inline const MarkerImageRenderer& DefaultRenderer() {
  static const MarkerImageRenderer renderer(DefaultSensor());
  return renderer;
}

/// The film without markers (the markers moved behind the camera), to paint markers out with.
inline cv::Mat RenderFilmOnly() {
  const std::vector<Eigen::Vector3d> away(DefaultSensor().MarkerPositions().size(), Eigen::Vector3d(0, 0, -1000));
  return DefaultRenderer().Render(away, 77);
}

}  // namespace tac3d::testing
