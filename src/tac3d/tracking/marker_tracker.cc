#include "tac3d/tracking/marker_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {

MarkerTracker::MarkerTracker(const SensorConfig& config, const MarkerTrackerOptions& options)
    : width_(config.camera.intrinsics.width), height_(config.camera.intrinsics.height), options_(options) {
  options_.Validate();
  const OpticalLayout layout = config.MakeOpticalLayout(true);
  const std::vector<Eigen::Vector3d> markers = config.MarkerPositions();
  const int rows = config.markers.rows, cols = config.markers.cols, n = rows * cols;
  for (ImageHalf which : kImageHalves) {
    const auto camera = std::find_if(config.virtual_cameras.begin(), config.virtual_cameras.end(),
                                     [&](const VirtualCameraConfig& v) { return v.half == which; });
    if (camera == config.virtual_cameras.end()) {
      throw Error(fmt::format("marker tracker: the sensor config has no virtual camera for the {} half",
                              ToString(which)));
    }
    const cv::Rect roi = cv::Rect(camera->column_begin, 0, camera->column_end - camera->column_begin, height_) &
                         cv::Rect(0, 0, width_, height_);
    if (roi.empty()) {
      throw Error(fmt::format("marker tracker: {} has no columns in the {} x {} image", camera->name, width_,
                              height_));
    }
    std::vector<Eigen::Vector2d> nominal(n);
    for (int i = 0; i < n; ++i) {
      const auto uv = ProjectPoint(layout, which, markers[i]);
      if (!uv || !roi.contains(cv::Point(static_cast<int>(std::lround(uv->x())),
                                         static_cast<int>(std::lround(uv->y()))))) {
        throw Error(fmt::format("marker tracker: marker {} (row {}, col {}) of the nominal sensor is "
                                "not seen in the {} half",
                                i, i / cols, i % cols, ToString(which)));
      }
      nominal[i] = *uv;
    }
    TAC3D_DEMAND(static_cast<int>(halves_.size()) == static_cast<int>(which));
    halves_.emplace_back(rows, cols, roi, std::move(nominal), options_,
                         fmt::format("the {} half", ToString(which)));
  }
}

void MarkerTracker::Reset() {
  for (GridTracker& half : halves_) half.Reset();
}

void MarkerTracker::Track(const cv::Mat& image, MarkerObservation& observation) {
  const auto start = std::chrono::steady_clock::now();
  CheckTrackerImage(image, width_, height_);
  observation.rows = halves_[0].rows();
  observation.cols = halves_[0].cols();
  auto& summary = observation.summary;
  summary = {};
  summary.frame_index = frame_index_++;
  for (int h = 0; h < 2; ++h) {
    HalfObservation& out = observation.halves[h];
    halves_[h].Track(image, out);
    summary.invalid_markers += static_cast<int>(out.state.size()) - out.valid_markers;
    summary.acquired |= out.acquired;
    summary.grid_lost |= out.grid_lost;
  }
  const int n = observation.rows * observation.cols;
  for (int i = 0; i < n; ++i) summary.paired_markers += observation.paired(i);
  summary.seconds = SecondsSince(start);
}

MarkerObservation MarkerTracker::Track(const cv::Mat& image) {
  MarkerObservation observation;
  Track(image, observation);
  return observation;
}

}  // namespace tac3d
