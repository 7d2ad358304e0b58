// Tracking a frame allocates nothing once the observation has been filled (CONVENTIONS.md,
// Performance), HalfObservation::estimate_uv (what the viewer draws lost markers at)
// included: malloc is counted around Track (testing/malloc_counter.h interposes glibc's
// malloc).

#include <cmath>

#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/testing/malloc_counter.h"
#include "tac3d/tracking/marker_tracker.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d {
namespace {

TEST(MarkerTracker, TrackingAFrameAllocatesNothing) {
  if (!testing::MallocIsCounted()) GTEST_SKIP() << "malloc is not countable under AddressSanitizer";
  const SensorConfig config = DefaultSensorConfig();
  MarkerTracker tracker(config);
  // Twin frames of a press coming and going, rendered before counting.
  const std::vector<Eigen::Vector3d> rest = config.MarkerPositions();
  const MarkerImageRenderer renderer(config);
  std::vector<cv::Mat> images;
  for (int k = 0; k < 16; ++k) {
    std::vector<Eigen::Vector3d> markers = rest;
    const double depth_mm = 0.6 * (0.5 - 0.5 * std::cos(2 * M_PI * k / 16.0));
    for (auto& p : markers) p.z() -= depth_mm * std::exp(-p.head<2>().squaredNorm() / 18.0);
    images.push_back(renderer.Render(markers, k));
  }
  // The first frame acquires the grid and sizes the observation; the counter must see it.
  MarkerObservation observation;
  long before = testing::MallocCalls();
  tracker.Track(images[0], observation);
  ASSERT_GT(testing::MallocCalls(), before);
  before = testing::MallocCalls();
  for (int pass = 0; pass < 2; ++pass) {
    for (const cv::Mat& image : images) tracker.Track(image, observation);
  }
  EXPECT_EQ(testing::MallocCalls() - before, 0);
  EXPECT_EQ(observation.summary.paired_markers, 400);
  EXPECT_FALSE(observation.summary.acquired);  // tracked, not re-acquired
}

}  // namespace
}  // namespace tac3d
