#include "tac3d/twin/vendor_optics.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tac3d/twin/camera_renderer.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

namespace tac3d {
namespace {

// The twin's rays of a vendor-calibrated sensor are VendorStereo's, at the camera's pixels: a
// pixel of the camera's image flipped as the vendor does, in the view that owns its column.
TEST(VendorOptics, TracesTheVendorsRaysInEachViewsColumns) {
  const SensorConfig config = testing::FixtureVendorSensor();
  const VendorOptics optics(config);
  const VendorStereo stereo(config);
  const VendorCameraModelConfig& model = *config.vendor_camera;
  const auto columns = model.ViewColumns(1920, 1080);
  for (const ImageHalf view : kImageHalves) {
    const auto [first, last] = columns[static_cast<int>(view)];
    for (const Eigen::Vector2d& pixel : {Eigen::Vector2d(first + 3, 200), Eigen::Vector2d(last - 4, 900),
                                        Eigen::Vector2d(0.5 * (first + last), 540)}) {
      const std::optional<HalfRay> traced = optics.Trace(pixel);
      ASSERT_TRUE(traced) << pixel.transpose();
      EXPECT_EQ(traced->half, view);
      const std::optional<Ray> expected = stereo.PixelRay(view, model.FlipPixel(pixel, 1920, 1080));
      ASSERT_TRUE(expected);
      EXPECT_LT((traced->ray.origin - expected->origin).norm(), 1e-12);
      EXPECT_LT((traced->ray.direction - expected->direction).norm(), 1e-12);
      // Project is Trace's inverse.
      const std::optional<Eigen::Vector2d> back = optics.Project(view, traced->ray.At(8.0));
      ASSERT_TRUE(back);
      EXPECT_LT((*back - pixel).norm(), 1e-6);
    }
  }
  EXPECT_FALSE(optics.Trace({-2.0, 500}));  // off the image
}

// The renderer through the vendor model: a 1920 x 1080 image whose darkest spot near each
// marker's projection is a dot (the film around it is bright), in both views.
TEST(VendorOptics, RendersTheMarkersWhereTheModelProjectsThem) {
  const SensorConfig config = testing::FixtureVendorSensor();
  RenderOptions options;
  options.noise = false;
  const MarkerImageRenderer renderer(config, options);
  const std::vector<Eigen::Vector3d> markers = config.MarkerPositions();
  const cv::Mat image = renderer.Render(markers);
  ASSERT_EQ(image.cols, 1920);
  ASSERT_EQ(image.rows, 1080);
  for (const ImageHalf view : kImageHalves) {
    for (const int i : {0, 19, 210, 380, 399}) {
      const std::optional<Eigen::Vector2d> uv = renderer.rays().optics().Project(view, markers[i]);
      ASSERT_TRUE(uv);
      // Midway to a grid neighbour is film: half a pitch (0.51 mm) from both dots' centres,
      // beyond their 0.3 mm radius.
      const int neighbour = i % 20 == 19 ? i - 1 : i + 1;
      const std::optional<Eigen::Vector2d> next = renderer.rays().optics().Project(view, markers[neighbour]);
      ASSERT_TRUE(next);
      const Eigen::Vector2d between = 0.5 * (*uv + *next);
      const int dot = image.at<std::uint8_t>(static_cast<int>(std::lround(uv->y())), static_cast<int>(std::lround(uv->x())));
      const int film =
          image.at<std::uint8_t>(static_cast<int>(std::lround(between.y())), static_cast<int>(std::lround(between.x())));
      EXPECT_LT(dot, 0.5 * film) << ToString(view) << " marker " << i << " at " << uv->transpose();
    }
  }
}

}  // namespace
}  // namespace tac3d
