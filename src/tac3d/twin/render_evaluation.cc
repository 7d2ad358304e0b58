#include "tac3d/twin/render_evaluation.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/features2d.hpp>

#include "tac3d/twin/camera_renderer.h"

namespace tac3d {
namespace {

std::array<int, 2> CountDarkBlobs(const cv::Mat& image, int split_column) {
  cv::SimpleBlobDetector::Params params;
  params.filterByColor = true;
  params.blobColor = 0;
  params.minThreshold = 40;
  params.maxThreshold = 200;
  params.thresholdStep = 10;
  params.filterByArea = true;
  params.minArea = 4;
  params.maxArea = 400;
  params.filterByCircularity = false;
  params.filterByInertia = false;
  params.filterByConvexity = false;
  params.minDistBetweenBlobs = 3;
  std::vector<cv::KeyPoint> keypoints;
  cv::SimpleBlobDetector::create(params)->detect(image, keypoints);
  std::array<int, 2> count = {0, 0};
  for (const auto& k : keypoints) ++count[k.pt.x < split_column ? 0 : 1];
  return count;
}

}  // namespace

RenderEvaluation EvaluateRender(const SensorConfig& config, int timing_frames) {
  RenderEvaluation result;
  const auto markers = config.MarkerPositions();
  const int split = static_cast<int>(std::ceil(config.camera.intrinsics.cx));

  const MarkerImageRenderer noisy(config);
  result.blobs_per_half = CountDarkBlobs(noisy.Render(markers), split);

  RenderOptions clean;
  clean.noise = false;
  clean.vignetting = 0.0;
  const MarkerImageRenderer renderer(config, clean);
  const cv::Mat image = renderer.Render(markers);
  const OpticalLayout layout = config.MakeOpticalLayout(true);
  const double film_dn = 255.0 * clean.film_level;
  // Half the pitch in the image is about 6 px: a window of +-4 px holds one dot.
  constexpr int kWindow = 4;
  std::vector<double> errors;
  for (const auto& p : markers) {
    for (ImageHalf half : kImageHalves) {
      const auto expected = ProjectPoint(layout, half, p);
      if (!expected) continue;
      const int u0 = static_cast<int>(std::lround(expected->x()));
      const int v0 = static_cast<int>(std::lround(expected->y()));
      if (u0 < kWindow || v0 < kWindow || u0 + kWindow >= image.cols || v0 + kWindow >= image.rows) {
        continue;
      }
      double sum = 0, su = 0, sv = 0;
      for (int v = v0 - kWindow; v <= v0 + kWindow; ++v) {
        for (int u = u0 - kWindow; u <= u0 + kWindow; ++u) {
          const double darkness = std::max(0.0, film_dn - image.at<std::uint8_t>(v, u));
          sum += darkness;
          su += darkness * u;
          sv += darkness * v;
        }
      }
      if (sum <= 0) continue;
      errors.push_back((Eigen::Vector2d(su / sum, sv / sum) - *expected).norm());
    }
  }
  result.dots_measured = static_cast<int>(errors.size());
  if (!errors.empty()) {
    std::sort(errors.begin(), errors.end());
    result.centroid_error_median_px = errors[errors.size() / 2];
    result.centroid_error_max_px = errors.back();
  }

  std::vector<double> times;
  for (int f = 0; f < timing_frames; ++f) {
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat frame = noisy.Render(markers, static_cast<std::uint64_t>(f));
    times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  if (!times.empty()) {
    std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
    result.render_median_ms = times[times.size() / 2];
  }
  return result;
}

}  // namespace tac3d
