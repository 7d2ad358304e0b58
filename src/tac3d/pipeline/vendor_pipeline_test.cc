#include <cmath>
#include <cstdio>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/stereo/marker_field.h"
#include "tac3d/tracking/marker_tracker.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

// The chain on twin images of a vendor-calibrated sensor: HDL1-0001 as the fixture's calibration
// imports it (1920 x 1080, two views in the one image, refraction at z = h0), rendered by the twin
// through the vendor's model (VendorOptics) and measured by the pipeline seeded from the reference
// pixels (VendorMarkerTriangulator). The twin's images are discs with blur, noise and 8-bit
// quantisation, moved by a known displacement field. The compliance is the synthetic half-space H
// at the gel's E and nu, a stand-in for the FEM's.

namespace tac3d {
namespace {

const SensorConfig& Hdl1() {
  static const SensorConfig config = testing::FixtureVendorSensor();
  return config;
}

const MarkerImageRenderer& Hdl1Renderer() {
  static const MarkerImageRenderer renderer(Hdl1());
  return renderer;
}

// The twin's markers: where the reference pixels triangulate (the real markers, in the vendor's
// order: row 0 at +y, column 0 at +x), as the compliance model has them.
const std::vector<Eigen::Vector3d>& Hdl1Markers() {
  static const std::vector<Eigen::Vector3d> markers = RestMarkerPositions(Hdl1());
  return markers;
}

const Eigen::MatrixXd& Hdl1Compliance() {
  static const Eigen::MatrixXd h =
      CalcSyntheticCompliance({.rows = Hdl1().markers.rows,
                               .cols = Hdl1().markers.cols,
                               .pitch_mm = Hdl1().markers.pitch_mm,
                               .youngs_modulus_mpa = Hdl1().elastic_body.youngs_modulus_mpa,
                               .poisson_ratio = Hdl1().elastic_body.poisson_ratio})
          .h;
  return h;
}

// A press of 2.5 N into the gel and 0.6 N along +y, Gaussian (sigma 2 mm) about (1, 1.5) mm.
Eigen::VectorXd PressForces(const std::vector<Eigen::Vector3d>& markers) {
  const int n = static_cast<int>(markers.size());
  Eigen::VectorXd weights(n);
  for (int i = 0; i < n; ++i) {
    weights[i] = std::exp(-(markers[i].head<2>() - Eigen::Vector2d(1, 1.5)).squaredNorm() / (2 * 4.0));
  }
  weights /= weights.sum();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  f.segment(n, n) = 0.6 * weights;
  f.segment(2 * n, n) = -2.5 * weights;
  return f;
}

std::vector<Eigen::Vector3d> Displaced(const std::vector<Eigen::Vector3d>& rest, const Eigen::VectorXd& d) {
  const int n = static_cast<int>(rest.size());
  std::vector<Eigen::Vector3d> moved = rest;
  for (int i = 0; i < n; ++i) moved[i] += Eigen::Vector3d(d[i], d[n + i], d[2 * n + i]);
  return moved;
}

// The blob detector's pixel sizes are the built-in sensor's (640 x 480, pitch up to 16 px) as
// given; a 1920 x 1080 sensor's dots (up to ~42 px apart) get them scaled.
TEST(VendorPipeline, BlobSizesScaleWithTheImage) {
  const MarkerTrackerOptions options;
  const BlobOptions builtin = MarkerTracker(testing::DefaultSensor(), options).blob_options();
  EXPECT_EQ(builtin.max_spread_px, options.blob.max_spread_px);
  EXPECT_EQ(builtin.max_area_px, options.blob.max_area_px);
  EXPECT_EQ(builtin.background_kernel_px, options.blob.background_kernel_px);
  const BlobOptions hdl1 = MarkerTracker(Hdl1(), options).blob_options();
  EXPECT_GT(hdl1.max_spread_px, 2 * options.blob.max_spread_px);
  EXPECT_GT(hdl1.max_area_px, 4 * options.blob.max_area_px);
  EXPECT_EQ(hdl1.background_kernel_px % 2, 1);
  EXPECT_NO_THROW(hdl1.Validate());
}

// Tracking and triangulation alone: every marker of a rendered 1920 x 1080 image found in both
// views and triangulated near where the twin put it. Measured 2026-11-26: RMS 0.0065 mm, max
// 0.0083 mm (the dots are discs up to 25 px across seen obliquely through the refraction: their
// centroids are not their centres' images; a displacement cancels most of that bias). The
// bounds fail a measuring disk that cuts the dots (0.0196 / 0.079 mm when it was placed about
// each dot's darkest pixel).
TEST(VendorPipeline, TracksAndTriangulatesRenderedMarkers) {
  const std::vector<Eigen::Vector3d>& rest = Hdl1Markers();
  const cv::Mat image = Hdl1Renderer().Render(rest, 0);
  ASSERT_EQ(image.cols, 1920);
  ASSERT_EQ(image.rows, 1080);
  MarkerTracker tracker(Hdl1());
  const MarkerObservation observation = tracker.Track(image);
  EXPECT_EQ(observation.summary.paired_markers, 400);
  MarkerField field;
  VendorMarkerTriangulator(Hdl1(), 0.15)
      .Triangulate(observation.half(ImageHalf::kLeft).uv, observation.half(ImageHalf::kRight).uv, field);
  double sq = 0, worst = 0;
  for (size_t i = 0; i < rest.size(); ++i) {
    ASSERT_TRUE(field.valid[i]) << i;
    const double e = (field.positions[i] - rest[i]).norm();
    sq += e * e;
    worst = std::max(worst, e);
  }
  const double rms = std::sqrt(sq / rest.size());
  std::printf("rendered HDL1-0001 markers: position error RMS %.4f mm, max %.4f mm\n", rms, worst);
  EXPECT_LT(rms, 0.012);
  EXPECT_LT(worst, 0.03);
}

// The whole chain, `tac3d run`'s Pipeline: the reference from static frames, then a press whose
// displacements (D = H F) come back within 0.01 mm RMS and whose resultant within 2 % of the
// full scale per axis (10 N normal, 5 N tangential, as `tac3d eval replay`). Measured 2026-11-26:
// RMSE 0.0007 mm; resultant (0.000, 0.589, -2.440) N for (0, 0.6, -2.5) N, 0.2 / 0.6 % FS.
TEST(VendorPipeline, RecoversAKnownPressOnTheImportedSensor) {
  const std::vector<Eigen::Vector3d>& rest = Hdl1Markers();
  PipelineOptions options;
  options.sn = "HDL1-0001";
  options.reference_frames = 3;
  Pipeline pipeline(Hdl1(), Hdl1Compliance(), rest, options);
  TactileFrame out;
  std::int64_t index = 0;
  auto step = [&](const std::vector<Eigen::Vector3d>& markers) {
    pipeline.Process({Hdl1Renderer().Render(markers, index), 0.01 * index, index}, out);
    ++index;
  };
  for (int k = 0; k < 3; ++k) step(rest);
  EXPECT_FALSE(out.has(FrameFlag::kInitializing));
  const Eigen::VectorXd f_true = PressForces(rest);
  const Eigen::VectorXd d_true = Hdl1Compliance() * f_true;
  step(Displaced(rest, d_true));
  EXPECT_EQ(out.flags, 0u) << FrameFlagNames(out.flags);
  const int n = static_cast<int>(rest.size());
  double sq = 0;
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(out.valid[i]) << i;
    sq += (out.displacements_mm[i] - Eigen::Vector3d(d_true[i], d_true[n + i], d_true[2 * n + i])).squaredNorm();
  }
  const double rmse = std::sqrt(sq / n);
  const Eigen::Vector3d total(f_true.segment(0, n).sum(), f_true.segment(n, n).sum(), f_true.segment(2 * n, n).sum());
  std::printf("HDL1-0001 twin press: displacement RMSE %.4f mm (max |d| %.3f mm); resultant %s N, true %s N\n", rmse,
              d_true.cwiseAbs().maxCoeff(), ::testing::PrintToString(out.resultant_force_n.transpose()).c_str(),
              ::testing::PrintToString(total.transpose()).c_str());
  EXPECT_LT(rmse, 0.01);
  const Eigen::Vector3d full_scale_n(5.0, 5.0, 10.0);
  for (int a = 0; a < 3; ++a) EXPECT_LT(std::abs(out.resultant_force_n[a] - total[a]), 0.02 * full_scale_n[a]) << a;
}

// An imported sensor's frames carry its own serial number unless one is given (`tac3d run`
// without --sn, Python's Pipeline without sn); the built-in sensor's the twin's.
TEST(VendorPipeline, FramesCarryTheImportedSensorsSerialNumber) {
  EXPECT_EQ(DefaultSerialNumber(Hdl1()), "HDL1-0001");
  EXPECT_EQ(DefaultSerialNumber(testing::DefaultSensor()), PipelineOptions{}.sn);
  SensorConfig unnamed = Hdl1();
  unnamed.vendor_camera->serial_number.clear();
  EXPECT_EQ(DefaultSerialNumber(unnamed), PipelineOptions{}.sn);
}

}  // namespace
}  // namespace tac3d
