// The camera image as the viewer shows it: downscaled, with the tracked markers drawn on it.

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "tac3d/tracking/marker_tracker.h"
#include "tac3d/util/error.h"
#include "tac3d/web/web_server.h"

namespace tac3d {
namespace {

// BGR; the page's legend (page/viewer.css) shows the same.
const cv::Scalar kTrackedBgr(0, 220, 0);
const cv::Scalar kLostBgr(40, 40, 255);
const cv::Scalar kDisplacementBgr(0, 230, 255);

// cv::circle and cv::line take sub-pixel points as fixed point with this many fraction bits.
constexpr int kShift = 4;

cv::Point FixedPoint(const Eigen::Vector2d& p) {
  return {static_cast<int>(std::lround(p.x() * (1 << kShift))), static_cast<int>(std::lround(p.y() * (1 << kShift)))};
}

}  // namespace

void AppendImageMarkers(const GridObservation& view, std::vector<ImageMarker>& markers) {
  for (size_t i = 0; i < view.state.size(); ++i) {
    const bool tracked = view.state[i] == MarkerState::kValid;
    if (tracked && i < view.uv.size()) {
      markers.push_back({view.uv[i].cast<float>(), true});
    } else if (!tracked && i < view.estimate_uv.size() && view.estimate_uv[i].allFinite()) {
      markers.push_back({view.estimate_uv[i].cast<float>(), false});
    }
  }
}

void ImageMarkersOf(const MarkerObservation& observation, std::vector<ImageMarker>& markers) {
  markers.clear();
  for (const HalfObservation& half : observation.halves) AppendImageMarkers(half, markers);
}

cv::Mat DrawCameraImage(const cv::Mat& image, const std::vector<ImageMarker>& markers, int width) {
  TAC3D_DEMAND(!image.empty() && image.type() == CV_8UC1 && width > 0);
  const double scale = std::min(1.0, width / static_cast<double>(image.cols));
  cv::Mat small;
  cv::resize(image, small, cv::Size(), scale, scale, cv::INTER_AREA);
  if (markers.empty()) return small;
  cv::Mat bgr;
  cv::cvtColor(small, bgr, cv::COLOR_GRAY2BGR);
  // A ring or cross of 4 camera px (at least 2 drawn px): inside the marker pitch (9-16 px for
  // the built-in sensor), so neighbours stay apart.
  const double radius = std::max(2.0, 4.0 * scale);
  const int radius_fixed = static_cast<int>(std::lround(radius * (1 << kShift)));
  for (const ImageMarker& m : markers) {
    if (!m.uv_px.allFinite()) continue;
    // Pixel centres: full-image pixel u lands at (u + 0.5) * scale - 0.5 (cv::resize's mapping).
    const Eigen::Vector2d at = ((m.uv_px.cast<double>().array() + 0.5) * scale - 0.5).matrix();
    if (m.tracked) {
      cv::circle(bgr, FixedPoint(at), radius_fixed, kTrackedBgr, 1, cv::LINE_AA, kShift);
    } else {
      const double d = radius / std::sqrt(2.0);
      cv::line(bgr, FixedPoint(at + Eigen::Vector2d(-d, -d)), FixedPoint(at + Eigen::Vector2d(d, d)), kLostBgr, 1,
               cv::LINE_AA, kShift);
      cv::line(bgr, FixedPoint(at + Eigen::Vector2d(-d, d)), FixedPoint(at + Eigen::Vector2d(d, -d)), kLostBgr, 1,
               cv::LINE_AA, kShift);
    }
  }
  return bgr;
}

cv::Mat DrawDisplacementImage(const cv::Mat& image, const GridObservation& view, const GridObservation& reference) {
  TAC3D_DEMAND(reference.estimate_uv.size() == view.state.size());
  std::vector<ImageMarker> markers;
  AppendImageMarkers(view, markers);
  cv::Mat picture = DrawCameraImage(image, markers, image.cols);
  if (picture.channels() == 1) cv::cvtColor(picture, picture, cv::COLOR_GRAY2BGR);
  for (size_t i = 0; i < view.state.size(); ++i) {
    const Eigen::Vector2d& from = reference.estimate_uv[i];
    if (!view.valid(static_cast<int>(i)) || (view.uv[i] - from).norm() < 0.5) continue;
    cv::arrowedLine(picture, FixedPoint(from), FixedPoint(view.uv[i]), kDisplacementBgr, 1, cv::LINE_AA, kShift, 0.3);
  }
  return picture;
}

}  // namespace tac3d
