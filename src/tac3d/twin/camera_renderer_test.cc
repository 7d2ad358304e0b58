#include "tac3d/twin/camera_renderer.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "tac3d/design/light_path_design.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

const SensorConfig& Sensor() {
  static const SensorConfig config = DefaultSensorConfig();
  return config;
}

// Plain OpenCV blob detection of dark dots, counted per image half.
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

TEST(MarkerImageRenderer, WholeGridIsSeenInEachHalf) {
  const MarkerImageRenderer renderer(Sensor());
  const cv::Mat image = renderer.Render(Sensor().MarkerPositions());
  ASSERT_EQ(image.type(), CV_8UC1);
  ASSERT_EQ(image.cols, 640);
  ASSERT_EQ(image.rows, 480);
  const auto count = CountDarkBlobs(image, Sensor().virtual_cameras[1].column_begin);
  EXPECT_EQ(count[0], 400);
  EXPECT_EQ(count[1], 400);
}

// The darkness-weighted centroid of each marker's image against the exact projection of
// its centre through the mirrors, glass and silicone.
TEST(MarkerImageRenderer, DotCentroidsMatchTheRayTracedProjection) {
  RenderOptions options;
  options.noise = false;
  options.vignetting = 0.0;
  const MarkerImageRenderer renderer(Sensor(), options);
  const auto markers = Sensor().MarkerPositions();
  const cv::Mat image = renderer.Render(markers);
  const OpticalLayout layout = Sensor().MakeOpticalLayout(true);
  const double film_dn = 255.0 * options.film_level;
  double worst = 0.0;
  int measured = 0;
  for (size_t k = 0; k < markers.size(); ++k) {
    for (ImageHalf half : kImageHalves) {
      const Eigen::Vector2d expected = ProjectPoint(layout, half, markers[k]).value();
      // A window that holds this dot and none of its neighbours (>= 8 px away).
      const int r = 4;
      double sum = 0, su = 0, sv = 0;
      const int u0 = static_cast<int>(std::lround(expected.x()));
      const int v0 = static_cast<int>(std::lround(expected.y()));
      for (int v = v0 - r; v <= v0 + r; ++v) {
        for (int u = u0 - r; u <= u0 + r; ++u) {
          const double darkness = std::max(0.0, film_dn - image.at<std::uint8_t>(v, u));
          sum += darkness;
          su += darkness * u;
          sv += darkness * v;
        }
      }
      ASSERT_GT(sum, 0.0);
      const double error = (Eigen::Vector2d(su / sum, sv / sum) - expected).norm();
      worst = std::max(worst, error);
      ++measured;
    }
  }
  EXPECT_EQ(measured, 800);
  EXPECT_LT(worst, 0.05);
  std::printf("worst centroid error over %d dot images: %.4f px\n", measured, worst);
}

TEST(MarkerImageRenderer, SameSeedSameImageOtherFrameOtherNoise) {
  const MarkerImageRenderer renderer(Sensor());
  const auto markers = Sensor().MarkerPositions();
  const cv::Mat a = renderer.Render(markers, 3), b = renderer.Render(markers, 3);
  const cv::Mat c = renderer.Render(markers, 4);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
}

TEST(MarkerImageRenderer, MovedMarkersMoveTheirImage) {
  RenderOptions options;
  options.noise = false;
  const MarkerImageRenderer renderer(Sensor(), options);
  auto markers = Sensor().MarkerPositions();
  const cv::Mat before = renderer.Render(markers);
  for (auto& p : markers) p.x() += 0.5;
  const cv::Mat after = renderer.Render(markers);
  EXPECT_GT(cv::norm(before, after, cv::NORM_L1), 1000.0);
}

TEST(MarkerImageRenderer, RefusesAWrongMarkerCount) {
  const MarkerImageRenderer renderer(Sensor());
  EXPECT_THROW(renderer.Render({Eigen::Vector3d::Zero()}), Error);
}

TEST(RenderOptions, AreValidated) {
  RenderOptions o;
  o.film_level = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.vignetting = 1.0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.blur_sigma_px = -1;
  EXPECT_THROW(o.Validate(), Error);
}

TEST(BoardImageRenderer, OpenCvFindsTheCircleGridInBothHalves) {
  for (const auto layout : {DotBoard::Layout::kSymmetric, DotBoard::Layout::kAsymmetric}) {
    DotBoard board;
    board.layout = layout;
    board.rows = layout == DotBoard::Layout::kSymmetric ? 7 : 9;
    board.cols = layout == DotBoard::Layout::kSymmetric ? 7 : 4;
    const BoardImageRenderer renderer(Sensor());
    const cv::Mat image = renderer.Render(board, board.SensorFromBoard(Eigen::Vector3d::Zero()));
    const int split = Sensor().virtual_cameras[1].column_begin;
    for (const cv::Rect roi : {cv::Rect(0, 0, split, 480), cv::Rect(split, 0, 640 - split, 480)}) {
      std::vector<cv::Point2f> centres;
      const int flags = layout == DotBoard::Layout::kSymmetric ? cv::CALIB_CB_SYMMETRIC_GRID
                                                               : cv::CALIB_CB_ASYMMETRIC_GRID;
      const bool found = cv::findCirclesGrid(image(roi), cv::Size(board.cols, board.rows), centres, flags);
      EXPECT_TRUE(found) << (layout == DotBoard::Layout::kSymmetric ? "symmetric" : "asymmetric")
                         << " grid in the half at x = " << roi.x;
    }
  }
}

TEST(DotBoard, PoseTurnsAboutTheBoardCentre) {
  DotBoard board;
  const Eigen::Vector3d centre(1, 2, 3);
  const Rigid3 pose = board.SensorFromBoard(centre, {0, 30, 0});
  const Eigen::Vector2d mid = 0.5 * (board.Min() + board.Max());
  EXPECT_THAT((pose * Eigen::Vector3d(mid.x(), mid.y(), 0)).eval(), EigenNear(centre, 1e-12));
  EXPECT_NEAR(RotationAngleDeg(pose.linear(), Eigen::Matrix3d::Identity()), 30.0, 1e-9);
}

TEST(DotBoard, Validates) {
  DotBoard board;
  board.dot_diameter_mm = board.spacing_mm;
  EXPECT_THROW(board.Validate(), Error);
  board = {};
  board.rows = 1;
  EXPECT_THROW(board.Validate(), Error);
}

}  // namespace
}  // namespace tac3d
