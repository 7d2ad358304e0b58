#include "tac3d/tracking/blob_detector.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A dark Gaussian dot (sigma 1.2 px, 150 DN deep) on a film that brightens linearly across
// the image (uneven light), exactly sampled at pixel centres, no noise.
cv::Mat Dot(const Eigen::Vector2d& center, double film_slope_dn_per_px = 0.0, int size = 40) {
  cv::Mat image(size, size, CV_8UC1);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const double r2 = (Eigen::Vector2d(x, y) - center).squaredNorm();
      const double film = 180.0 + film_slope_dn_per_px * (x - 20);
      image.at<std::uint8_t>(y, x) =
          cv::saturate_cast<std::uint8_t>(film - 150.0 * std::exp(-r2 / (2 * 1.2 * 1.2)));
    }
  }
  return image;
}

const cv::Rect kWhole(0, 0, 40, 40);

TEST(MeasureBlob, SubPixelCentroidOfASymmetricDot) {
  // Errors: 8-bit rounding, and the weight threshold cutting a dot sampled at only a few
  // pixels unevenly; together under 0.03 px.
  for (const Eigen::Vector2d& center : {Eigen::Vector2d(20.0, 20.0), Eigen::Vector2d(19.3, 20.45),
                                       Eigen::Vector2d(20.71, 19.86)}) {
    Blob blob;
    ASSERT_EQ(MeasureBlob(Dot(center), kWhole, Eigen::Vector2d(20, 20), 3.0, 4.5, {}, blob),
              BlobStatus::kFound);
    EXPECT_LT((blob.center - center).norm(), 0.03) << center.transpose();
    // The darkest pixel is the one nearest the centre.
    const Eigen::Vector2d nearest = center.array().round();
    const double depth = 150.0 * std::exp(-(nearest - center).squaredNorm() / (2 * 1.2 * 1.2));
    EXPECT_NEAR(blob.contrast_dn, depth, 1.0);
    EXPECT_LT(blob.elongation, 1.2);
  }
}

TEST(MeasureBlob, UnevenLightBarelyMovesTheCentroid) {
  // The background is one level (the ring's median), so a brightness gradient across the
  // dot tips its weights: 0.5 DN per px, twice the steepest vignetting of the twin,
  // moves the centroid by less than 0.03 px more than a flat film does.
  const Eigen::Vector2d center(20.3, 19.6);
  Blob flat, tilted;
  ASSERT_EQ(MeasureBlob(Dot(center), kWhole, Eigen::Vector2d(20, 20), 3.0, 4.5, {}, flat),
            BlobStatus::kFound);
  ASSERT_EQ(MeasureBlob(Dot(center, 0.5), kWhole, Eigen::Vector2d(20, 20), 3.0, 4.5, {}, tilted),
            BlobStatus::kFound);
  EXPECT_LT((tilted.center - flat.center).norm(), 0.03);
  // The local background follows the light: a dot on a film 20 DN darker is the same dot.
  cv::Mat dim = Dot(center);
  dim -= 20;
  Blob dimmed;
  ASSERT_EQ(MeasureBlob(dim, kWhole, Eigen::Vector2d(20, 20), 3.0, 4.5, {}, dimmed), BlobStatus::kFound);
  EXPECT_LT((dimmed.center - flat.center).norm(), 0.03);
}

TEST(MeasureBlob, AWideDiskMeasuresTheSameDot) {
  // On a flat film only the dot's pixels weigh, so a disk of 70 px (rows of several vectors,
  // and rows past the 64 whose half widths are tabulated) must give exactly what one of
  // 4.5 px gives.
  const cv::Mat image = Dot({80.3, 79.6}, 0.0, 160);
  const cv::Rect whole(0, 0, 160, 160);
  Blob small, wide;
  ASSERT_EQ(MeasureBlob(image, whole, {80, 80}, 3.0, 4.5, {}, small), BlobStatus::kFound);
  ASSERT_EQ(MeasureBlob(image, whole, {80, 80}, 3.0, 70.0, {}, wide), BlobStatus::kFound);
  EXPECT_EQ(wide.center, small.center);
  EXPECT_EQ(wide.spread_px, small.spread_px);
  EXPECT_LT((wide.center - Eigen::Vector2d(80.3, 79.6)).norm(), 0.03);
}

TEST(MeasureBlob, FlatDarkOrOutOfViewImagesHaveNoBlob) {
  Blob blob;
  const cv::Mat flat(40, 40, CV_8UC1, cv::Scalar(180));
  EXPECT_EQ(MeasureBlob(flat, kWhole, Eigen::Vector2d(20, 20), 3.0, 4.5, {}, blob), BlobStatus::kNoBlob);
  const cv::Mat black = cv::Mat::zeros(40, 40, CV_8UC1);
  EXPECT_EQ(MeasureBlob(black, kWhole, Eigen::Vector2d(20, 20), 3.0, 4.5, {}, blob), BlobStatus::kNoBlob);
  const cv::Mat dot = Dot({20, 20});
  EXPECT_EQ(MeasureBlob(dot, kWhole, Eigen::Vector2d(60, 20), 3.0, 4.5, {}, blob), BlobStatus::kNoBlob);
  EXPECT_EQ(MeasureBlob(dot, kWhole, Eigen::Vector2d(NAN, 20), 3.0, 4.5, {}, blob), BlobStatus::kNoBlob);
  // The dot is outside the region the caller may read (the other image half).
  EXPECT_EQ(MeasureBlob(dot, cv::Rect(0, 0, 14, 40), Eigen::Vector2d(12, 20), 3.0, 4.5, {}, blob),
            BlobStatus::kNoBlob);
}

TEST(MeasureBlob, MergedPairAndSpeckleAreBadShapes) {
  // Two dots 3.5 px apart make one long blob.
  cv::Mat pair = Dot({18.25, 20});
  cv::min(pair, Dot({21.75, 20}), pair);
  Blob blob;
  EXPECT_EQ(MeasureBlob(pair, kWhole, Eigen::Vector2d(20, 20), 3.0, 5.5, {}, blob),
            BlobStatus::kBadShape);
  // Sparse dark speckle on the film.
  cv::Mat speckle(40, 40, CV_8UC1, cv::Scalar(180));
  cv::RNG rng(7);
  for (int k = 0; k < 60; ++k) speckle.at<std::uint8_t>(rng.uniform(14, 27), rng.uniform(14, 27)) = 40;
  EXPECT_EQ(MeasureBlob(speckle, kWhole, Eigen::Vector2d(20, 20), 3.0, 5.5, {}, blob),
            BlobStatus::kBadShape);
}

TEST(DetectBlobs, FindsEveryMarkerOfATwinFrameAndNothingInBlackOrNoise) {
  const SensorConfig sensor = DefaultSensorConfig();
  const cv::Mat image = MarkerImageRenderer(sensor).Render(sensor.MarkerPositions());
  for (const VirtualCameraConfig& camera : sensor.virtual_cameras) {
    const cv::Rect roi(camera.column_begin, 0, camera.column_end - camera.column_begin, image.rows);
    const std::vector<Blob> blobs = DetectBlobs(image, roi, {});
    EXPECT_EQ(blobs.size(), 400u) << camera.name;
    for (const Blob& b : blobs) EXPECT_TRUE(roi.contains(cv::Point(b.center.x(), b.center.y())));
  }
  const cv::Rect whole(0, 0, 640, 480);
  EXPECT_TRUE(DetectBlobs(cv::Mat::zeros(480, 640, CV_8UC1), whole, {}).empty());
  cv::Mat noise(480, 640, CV_8UC1);
  cv::RNG(11).fill(noise, cv::RNG::UNIFORM, 0, 256);
  // Uniform noise is one huge dark component, not a field of dots.
  EXPECT_LT(DetectBlobs(noise, whole, {}).size(), 20u);
}

TEST(BlobOptions, ValidateNamesTheField) {
  BlobOptions options;
  options.max_spread_px = 0.1;
  try {
    options.Validate();
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_spread_px"), std::string::npos);
  }
  options = {};
  options.background_kernel_px = 4;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.weight_threshold = 1.0;
  EXPECT_THROW(options.Validate(), Error);
}

TEST(ScaleBlobOptions, ScalesPixelSizesForLargerDotsOnly) {
  const BlobOptions options;
  // Dots twice as large: radii and the closing's half side doubled, areas four times.
  const BlobOptions twice = ScaleBlobOptions(options, 2.0);
  EXPECT_EQ(twice.min_spread_px, 2 * options.min_spread_px);
  EXPECT_EQ(twice.max_spread_px, 2 * options.max_spread_px);
  EXPECT_EQ(twice.background_kernel_px, 2 * (options.background_kernel_px - 1) + 1);
  EXPECT_EQ(twice.min_area_px, 4 * options.min_area_px);
  EXPECT_EQ(twice.max_area_px, 4 * options.max_area_px);
  EXPECT_EQ(twice.min_contrast_dn, options.min_contrast_dn);  // not a size
  EXPECT_NO_THROW(twice.Validate());
  // Not larger: as given.
  for (double scale : {1.0, 0.5, std::nan("")}) {
    const BlobOptions same = ScaleBlobOptions(options, scale);
    EXPECT_EQ(same.max_spread_px, options.max_spread_px) << scale;
    EXPECT_EQ(same.max_area_px, options.max_area_px) << scale;
    EXPECT_EQ(same.background_kernel_px, options.background_kernel_px) << scale;
  }
}

}  // namespace
}  // namespace tac3d
