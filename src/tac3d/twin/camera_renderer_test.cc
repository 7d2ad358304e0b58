#include "tac3d/twin/camera_renderer.h"
#include "tac3d/twin/render_evaluation.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

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

// The real-image nuisances (docs/render.md, "Real-image nuisances") on the film alone (the
// markers moved behind the camera), noise and blur off so each is seen by itself.
std::vector<Eigen::Vector3d> MarkersAway() {
  return std::vector<Eigen::Vector3d>(DefaultSensor().MarkerPositions().size(),
                                      Eigen::Vector3d(0, 0, -1000));
}

RenderOptions Plain() {
  RenderOptions o;
  o.noise = false;
  o.blur_sigma_px = 0;
  return o;
}

TEST(MarkerImageRenderer, ColouredLedsLightEachChannelAsAsked) {
  RenderOptions coloured = Plain();
  coloured.led_colour = LedColour::GelSightMini();
  const MarkerImageRenderer grey_renderer(DefaultSensor(), Plain());
  const MarkerImageRenderer colour_renderer(DefaultSensor(), coloured);
  const cv::Mat irradiance = grey_renderer.RenderIrradiance(MarkersAway());
  const cv::Mat bgr = colour_renderer.RenderCamera(MarkersAway());
  ASSERT_EQ(bgr.type(), CV_8UC3);
  const CameraIntrinsics& c = DefaultSensor().camera.intrinsics;
  const LedColour& led = coloured.led_colour;
  // Each channel is the grey light times the LedColour formula, written out here once more.
  double worst_dn = 0;
  int film_pixels = 0;
  double red_top = 0, red_bottom = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const float grey = irradiance.at<float>(y, x);
      if (grey < 0.2f) continue;  // the housing, not the film
      ++film_pixels;
      const double xn = (x - c.cx) / (c.width - 1), yn = (y - c.cy) / (c.height - 1);
      const double r2 = ((x - c.cx) * (x - c.cx) + (y - c.cy) * (y - c.cy)) / (c.cx * c.cx + c.cy * c.cy);
      for (int ch = 0; ch < 3; ++ch) {
        const double expected = std::min(
            255.0, 255.0 * grey * led.gain[ch] *
                       std::exp(led.x_slope[ch] * xn + led.y_slope[ch] * yn - led.falloff[ch] * r2));
        worst_dn = std::max(worst_dn, std::abs(bgr.at<cv::Vec3b>(y, x)[ch] - expected));
      }
      if (std::abs(yn) > 0.3) (yn < 0 ? red_top : red_bottom) += bgr.at<cv::Vec3b>(y, x)[2] / grey;
    }
  }
  EXPECT_GT(film_pixels, 10000);
  EXPECT_LE(worst_dn, 0.51);  // 8-bit rounding
  // The video's magnitude: red relative to the grey light (summed over as many film pixels
  // above as below: the image is symmetric about its middle row) far stronger below.
  EXPECT_GT(red_bottom, 2.0 * red_top);
  // The pipeline's frame is that colour frame's luma, as a frame source converts it.
  cv::Mat luma;
  cv::cvtColor(bgr, luma, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(colour_renderer.Render(MarkersAway()), luma, cv::NORM_INF), 0.0);
}

TEST(MarkerImageRenderer, JpegQualityCompressesTheFrameAsAsked) {
  RenderOptions options = Plain().WithRealImageNuisances();
  options.blur_sigma_px = 0;
  options.jpeg_quality = 0;
  const auto markers = DefaultSensor().MarkerPositions();
  const cv::Mat raw = MarkerImageRenderer(DefaultSensor(), options).RenderCamera(markers);
  // Mean absolute change per value: a lower quality changes more, none leaves the frame.
  auto change = [&](int quality) {
    options.jpeg_quality = quality;
    const cv::Mat jpeg = MarkerImageRenderer(DefaultSensor(), options).RenderCamera(markers);
    EXPECT_EQ(jpeg.type(), raw.type());
    EXPECT_EQ(jpeg.size(), raw.size());
    return cv::norm(jpeg, raw, cv::NORM_L1) / raw.total() / raw.channels();
  };
  const double q85 = change(85), q30 = change(30);
  std::printf("JPEG mean absolute change: quality 85 %.3f DN, 30 %.3f DN\n", q85, q30);
  EXPECT_GT(q85, 0.1);
  EXPECT_GT(q30, 1.5 * q85);
}

TEST(RenderOptions, RealImageNuisancesAreTheMeasuredLevels) {
  const RenderOptions real = RenderOptions{}.WithRealImageNuisances();
  EXPECT_NO_THROW(real.Validate());
  EXPECT_FALSE(real.led_colour.IsWhite());
  EXPECT_TRUE(RenderOptions{}.led_colour.IsWhite());
  EXPECT_EQ(real.blur_sigma_px, 1.0);
  EXPECT_EQ(real.jpeg_quality, 85);
  // The gains' luma is 1: the grey level at the principal point stays the twin's.
  const Eigen::Vector3d gain = real.led_colour.gain;
  EXPECT_NEAR(0.114 * gain[0] + 0.587 * gain[1] + 0.299 * gain[2], 1.0, 0.002);
}

TEST(RenderOptions, RefuseBadRealImageNuisances) {
  RenderOptions o;
  o.jpeg_quality = 101;
  EXPECT_THAT([&] { o.Validate(); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "render options: jpeg_quality = 101 must be in [0, 100] (0: none)")));
  o = {};
  o.jpeg_quality = -1;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.led_colour.gain = {1, 0, 1};
  EXPECT_THAT([&] { o.Validate(); },
              ::testing::ThrowsMessage<Error>(
                  ::testing::HasSubstr("render options: led_colour.gain = 0 must be each in (0, 4]")));
  o = {};
  o.led_colour.falloff = {0, -0.5, 0};
  EXPECT_THAT([&] { o.Validate(); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "render options: led_colour.falloff = -0.5 must be each in [0, 5]")));
  o = {};
  o.led_colour.y_slope = {0, 0, 6};
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.led_colour.x_slope = {NAN, 0, 0};
  EXPECT_THROW(o.Validate(), Error);
  EXPECT_THROW(MarkerImageRenderer(DefaultSensor(), o), Error);
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
