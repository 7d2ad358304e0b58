#include "tac3d/twin/camera_renderer.h"
#include "tac3d/twin/render_evaluation.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "tac3d/design/light_path_design.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::DefaultSensor;

TEST(MarkerImageRenderer, WholeGridIsSeenAndDotsLandWhereTheRayTracerSaysInEachHalf) {
  const RenderEvaluation e = EvaluateRender(DefaultSensor(), /*timing_frames=*/0);
  // Plain OpenCV blob detection finds the whole 20 x 20 grid in each half.
  EXPECT_EQ(e.blobs_per_half[0], 400);
  EXPECT_EQ(e.blobs_per_half[1], 400);
  // Each dot's image centroid against the exact projection of its centre.
  EXPECT_EQ(e.dots_measured, 800);
  EXPECT_LT(e.centroid_error_max_px, 0.05);
  std::printf("centroid error over %d dot images: median %.4f px, max %.4f px\n", e.dots_measured,
              e.centroid_error_median_px, e.centroid_error_max_px);
}

TEST(MarkerImageRenderer, ImageHasTheCamerasSize) {
  const MarkerImageRenderer renderer(DefaultSensor());
  const cv::Mat image = renderer.Render(DefaultSensor().MarkerPositions());
  EXPECT_EQ(image.type(), CV_8UC1);
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
}

TEST(MarkerImageRenderer, SameSeedSameImageOtherFrameOtherNoise) {
  const MarkerImageRenderer renderer(DefaultSensor());
  const auto markers = DefaultSensor().MarkerPositions();
  const cv::Mat a = renderer.Render(markers, 3), b = renderer.Render(markers, 3);
  const cv::Mat c = renderer.Render(markers, 4);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
}

TEST(MarkerImageRenderer, MovedMarkersMoveTheirImage) {
  RenderOptions options;
  options.noise = false;
  const MarkerImageRenderer renderer(DefaultSensor(), options);
  auto markers = DefaultSensor().MarkerPositions();
  const cv::Mat before = renderer.Render(markers);
  for (auto& p : markers) p.x() += 0.5;
  const cv::Mat after = renderer.Render(markers);
  EXPECT_GT(cv::norm(before, after, cv::NORM_L1), 1000.0);
}

TEST(MarkerImageRenderer, RefusesAWrongMarkerCount) {
  const MarkerImageRenderer renderer(DefaultSensor());
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
  // Issue 22, defect 11: `render --read-noise 1e300` was accepted.
  o = {};
  o.read_noise_dn = 1e300;
  EXPECT_THAT([&] { o.Validate(); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "render options: read_noise_dn = 1e+300 must be in [0, 255] DN")));
  o = {};
  o.shot_noise_gain = 1e300;
  EXPECT_THROW(o.Validate(), Error);
}

TEST(BoardImageRenderer, OpenCvFindsTheCircleGridInBothHalves) {
  for (const auto layout : {CalibrationBoard::Layout::kSymmetric, CalibrationBoard::Layout::kAsymmetric}) {
    DotBoard board;
    board.grid.layout = layout;
    board.grid.rows = layout == CalibrationBoard::Layout::kSymmetric ? 7 : 9;
    board.grid.cols = layout == CalibrationBoard::Layout::kSymmetric ? 7 : 4;
    const BoardImageRenderer renderer(DefaultSensor());
    const cv::Mat image = renderer.Render(board, board.SensorFromBoard(Eigen::Vector3d::Zero()));
    const int split = DefaultSensor().virtual_cameras[1].column_begin;
    for (const cv::Rect roi : {cv::Rect(0, 0, split, 480), cv::Rect(split, 0, 640 - split, 480)}) {
      std::vector<cv::Point2f> centres;
      const int flags = layout == CalibrationBoard::Layout::kSymmetric ? cv::CALIB_CB_SYMMETRIC_GRID
                                                               : cv::CALIB_CB_ASYMMETRIC_GRID;
      const bool found = cv::findCirclesGrid(image(roi), cv::Size(board.grid.cols, board.grid.rows), centres, flags);
      EXPECT_TRUE(found) << (layout == CalibrationBoard::Layout::kSymmetric ? "symmetric" : "asymmetric")
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
  board.grid.dot_diameter_mm = board.grid.spacing_mm;
  EXPECT_THROW(board.Validate(), Error);
  board = {};
  board.margin_mm = -1;
  EXPECT_THROW(board.Validate(), Error);
  board = {};
  board.grid.rows = 1;
  EXPECT_THROW(board.Validate(), Error);
}

}  // namespace
}  // namespace tac3d
