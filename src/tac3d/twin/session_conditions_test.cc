#include "tac3d/twin/session_conditions.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tac3d/design/light_path_design.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/twin/calibration_set.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::DefaultSensor;

TEST(SessionConditions, RampsFromNothingToItsLevelsAndHolds) {
  const SessionConditions s = SessionConditions::Realistic();
  const FrameConditions start = s.At(0.0), half = s.At(0.5 * s.session_s), end = s.At(s.session_s);
  EXPECT_EQ(start.illumination_gain, 1.0);
  EXPECT_EQ(start.illumination_offset, 0.0);
  EXPECT_EQ(start.dot_contrast, 1.0);
  EXPECT_EQ(start.exposure, 1.0);
  EXPECT_EQ(start.creep_mm, Eigen::Vector3d::Zero());
  EXPECT_DOUBLE_EQ(half.illumination_gain, 1.0 + 0.5 * (s.illumination_gain - 1.0));
  EXPECT_DOUBLE_EQ(half.illumination_gradient, 0.5 * s.illumination_gradient);
  EXPECT_DOUBLE_EQ(end.illumination_gain, s.illumination_gain);
  EXPECT_DOUBLE_EQ(end.illumination_offset, s.illumination_offset);
  EXPECT_DOUBLE_EQ(end.dot_contrast, 1.0 - s.contrast_fade);
  EXPECT_DOUBLE_EQ(end.exposure, 1.0 + s.exposure_drift);
  EXPECT_TRUE(end.creep_mm.isApprox(Eigen::Vector3d(0, 0, -s.creep_mm)));
  EXPECT_EQ(s.At(10 * s.session_s).creep_mm, end.creep_mm);  // held after the session
  EXPECT_EQ(s.At(-1.0).creep_mm, Eigen::Vector3d::Zero());
}

TEST(SessionConditions, OnlyKeepsOneNuisance) {
  const SessionConditions all = SessionConditions::Realistic();
  const FrameConditions gain = all.Only(Nuisance::kIlluminationGain).At(all.session_s);
  EXPECT_DOUBLE_EQ(gain.illumination_gain, all.illumination_gain);
  EXPECT_EQ(gain.illumination_offset, 0.0);
  EXPECT_EQ(gain.dot_contrast, 1.0);
  EXPECT_EQ(gain.creep_mm, Eigen::Vector3d::Zero());
  const FrameConditions creep = all.Only(Nuisance::kCreep).At(all.session_s);
  EXPECT_EQ(creep.illumination_gain, 1.0);
  EXPECT_TRUE(creep.creep_mm.isApprox(Eigen::Vector3d(0, 0, -all.creep_mm)));
  EXPECT_EQ(ToString(Nuisance::kContrastFade), "contrast_fade");
}

TEST(SessionConditions, BadLevelsThrowNamingTheField) {
  auto throws = [](void (*set)(SessionConditions&), const char* field) {
    SessionConditions c;
    set(c);
    try {
      c.Validate();
      ADD_FAILURE() << field << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  throws([](SessionConditions& c) { c.session_s = 0; }, "session_s");
  throws([](SessionConditions& c) { c.illumination_gain = 0; }, "illumination_gain");
  throws([](SessionConditions& c) { c.illumination_offset = -0.1; }, "illumination_offset");
  throws([](SessionConditions& c) { c.illumination_gradient = 1; }, "illumination_gradient");
  throws([](SessionConditions& c) { c.contrast_fade = 1; }, "contrast_fade");
  throws([](SessionConditions& c) { c.exposure_drift = -1; }, "exposure_drift");
  throws([](SessionConditions& c) { c.creep_mm = -0.01; }, "creep_mm");
  throws([](SessionConditions& c) { c.creep_direction.setZero(); }, "creep_direction");
  EXPECT_NO_THROW(SessionConditions::Realistic().Validate());
}

// Each nuisance in the rendered light is what its truth says (linear light, no noise).
TEST(SessionConditions, TheRendererAppliesEachNuisance) {
  const MarkerImageRenderer renderer(DefaultSensor());
  const std::vector<Eigen::Vector3d> markers = DefaultSensor().MarkerPositions();
  const cv::Mat nominal = renderer.RenderIrradiance(markers);
  // A film pixel left and right of the centre, and the darkest pixel of marker 210's dot.
  const cv::Point left(100, 240), right(540, 240);
  ASSERT_GT(nominal.at<float>(left), 0.5f);
  ASSERT_GT(nominal.at<float>(right), 0.5f);
  const auto uv = renderer.rays().optics().Project(ImageHalf::kLeft, markers[210]);
  ASSERT_TRUE(uv.has_value());
  const cv::Point dot(static_cast<int>(std::lround(uv->x())),
                      static_cast<int>(std::lround(uv->y())));
  // The film behind the dot: RenderOptions' film level with its vignetting.
  const RenderOptions render;
  const CameraIntrinsics& k = DefaultSensor().camera.intrinsics;
  const double r2 =
      (std::pow(dot.x - k.cx, 2) + std::pow(dot.y - k.cy, 2)) / (k.cx * k.cx + k.cy * k.cy);
  const double film_at_dot = render.film_level * (1.0 - render.vignetting * r2);
  const double darkening = 1.0 - nominal.at<float>(dot) / film_at_dot;
  ASSERT_GT(darkening, 0.5);

  FrameConditions c;
  c.illumination_gain = 0.9;
  c.illumination_offset = 0.02;
  c.exposure = 1.1;
  const cv::Mat lit = renderer.RenderIrradiance(markers, c);
  EXPECT_NEAR(lit.at<float>(left), 1.1 * (0.9 * nominal.at<float>(left) + 0.02), 1e-6);

  FrameConditions gradient;
  gradient.illumination_gradient = 0.2;
  const cv::Mat tilted = renderer.RenderIrradiance(markers, gradient);
  const double cx = DefaultSensor().camera.intrinsics.cx;
  EXPECT_NEAR(
      tilted.at<float>(left) / nominal.at<float>(left), 1 + 0.2 * (left.x - cx) / 639, 1e-6);
  EXPECT_NEAR(
      tilted.at<float>(right) / nominal.at<float>(right), 1 + 0.2 * (right.x - cx) / 639, 1e-6);

  FrameConditions faded;
  faded.dot_contrast = 0.5;
  const cv::Mat pale = renderer.RenderIrradiance(markers, faded);
  EXPECT_NEAR(1.0 - pale.at<float>(dot) / film_at_dot, 0.5 * darkening, 1e-4);

  FrameConditions creep;
  creep.creep_mm = Eigen::Vector3d(0.01, 0, -0.02);
  std::vector<Eigen::Vector3d> moved = markers;
  for (auto& p : moved) p += creep.creep_mm;
  EXPECT_EQ(cv::norm(renderer.RenderIrradiance(markers, creep),
                     renderer.RenderIrradiance(moved),
                     cv::NORM_INF),
            0.0);
  // Nominal conditions render what the renderer always did.
  EXPECT_EQ(cv::norm(renderer.Render(markers, 3, FrameConditions{}),
                     renderer.Render(markers, 3),
                     cv::NORM_INF),
            0.0);
}

TEST(SessionConditions, ManufacturingSpreadMovesTheCameraWithinItsTolerances) {
  const SensorPerturbationOptions spread = SensorPerturbationOptions::ManufacturingSpread(3);
  double largest_tilt = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    SensorPerturbationOptions o = spread;
    o.seed = seed;
    const SensorConfig truth = PerturbSensor(DefaultSensor(), o);
    const Rigid3& a = DefaultSensor().camera.sensor_from_cam;
    const Rigid3& b = truth.camera.sensor_from_cam;
    const double tilt = RadToDeg(Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle());
    EXPECT_LE(tilt, spread.camera_tilt_max_deg + 1e-9);
    EXPECT_LE((a.translation() - b.translation()).norm(), spread.camera_shift_max_mm + 1e-12);
    largest_tilt = std::max(largest_tilt, tilt);
    // The virtual cameras are the moved camera's images in the mirrors.
    const OpticalLayout layout = truth.MakeOpticalLayout(false);
    for (const VirtualCameraConfig& v : truth.virtual_cameras) {
      EXPECT_TRUE(v.sensor_from_vcam.isApprox(layout.SensorFromVirtualCamera(v.half), 1e-12));
    }
  }
  EXPECT_GT(largest_tilt, 0.5 * spread.camera_tilt_max_deg);
  // Without camera tolerances (the default) the camera stays where the design put it.
  EXPECT_TRUE(PerturbSensor(DefaultSensor(), SensorPerturbationOptions{})
                  .camera.sensor_from_cam.isApprox(DefaultSensor().camera.sensor_from_cam, 0.0));
}

}  // namespace
}  // namespace tac3d
