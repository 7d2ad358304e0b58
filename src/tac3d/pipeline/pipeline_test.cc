#include "tac3d/pipeline/pipeline.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/testing/testing.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

// The chain on twin images. The compliance is the synthetic half-space H (force module), a
// stand-in with the FEM's ordering and smoothness; the markers are displaced by D = H F for a
// known F, so the forces the pipeline recovers can be compared with F.

namespace tac3d {
namespace {

const SensorConfig& Sensor() {
  static const SensorConfig config = DefaultSensorConfig();
  return config;
}

const Eigen::MatrixXd& H() {
  static const Eigen::MatrixXd h = CalcSyntheticCompliance({}).h;
  return h;
}

// A smooth press: 3 N into the body and 0.8 N along +x, Gaussian (sigma 2 mm) about (2, -1) mm.
Eigen::VectorXd TrueForces() {
  const std::vector<Eigen::Vector3d> markers = Sensor().MarkerPositions();
  const int n = static_cast<int>(markers.size());
  Eigen::VectorXd weights(n);
  for (int i = 0; i < n; ++i) {
    weights[i] = std::exp(-(markers[i].head<2>() - Eigen::Vector2d(2, -1)).squaredNorm() / (2 * 4.0));
  }
  weights /= weights.sum();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  f.segment(0, n) = 0.8 * weights;
  f.segment(2 * n, n) = -3.0 * weights;
  return f;
}

struct TwinStream {
  Pipeline pipeline;
  MarkerImageRenderer renderer;
  std::int64_t index = 0;

  explicit TwinStream(PipelineOptions options = {})
      : pipeline(Sensor(), H(), Sensor().MarkerPositions(), options), renderer(Sensor()) {}

  TactileFrame Step(const std::vector<Eigen::Vector3d>& markers) {
    Frame frame;
    frame.image = renderer.Render(markers, index);
    frame.timestamp_s = 0.01 * index;
    frame.index = index++;
    TactileFrame out;
    pipeline.Process(frame, out);
    return out;
  }
  TactileFrame StepImage(const cv::Mat& image) {
    Frame frame{image, 0.01 * index, index};
    ++index;
    TactileFrame out;
    pipeline.Process(frame, out);
    return out;
  }
};

PipelineOptions FiveReferenceFrames() {
  PipelineOptions options;
  options.reference_frames = 5;
  return options;
}

TEST(Pipeline, InitialisesThenRecoversAKnownForceDistribution) {
  TwinStream run(FiveReferenceFrames());
  const std::vector<Eigen::Vector3d> rest = Sensor().MarkerPositions();
  for (int k = 0; k < 4; ++k) {
    const TactileFrame f = run.Step(rest);
    EXPECT_EQ(f.initialize_progress, 20 * (k + 1));
    EXPECT_TRUE(f.has(FrameFlag::kInitializing));
    EXPECT_EQ(f.resultant_force_n, Eigen::Vector3d::Zero());
    EXPECT_NO_THROW(f.Validate());
  }
  const TactileFrame ready = run.Step(rest);
  EXPECT_EQ(ready.initialize_progress, 100);
  EXPECT_FALSE(ready.has(FrameFlag::kInitializing));
  EXPECT_LT(ready.resultant_force_n.norm(), 0.1);
  ASSERT_TRUE(run.pipeline.noise_variance().has_value());
  EXPECT_LT(run.pipeline.noise_variance()->maxCoeff(), 1e-4);  // sigma below 0.01 mm

  const Eigen::VectorXd f_true = TrueForces();
  const Eigen::VectorXd d_true = H() * f_true;
  const int n = static_cast<int>(rest.size());
  std::vector<Eigen::Vector3d> pressed = rest;
  for (int i = 0; i < n; ++i) pressed[i] += Eigen::Vector3d(d_true[i], d_true[n + i], d_true[2 * n + i]);
  const TactileFrame f = run.Step(pressed);
  EXPECT_EQ(f.sn, "TAC3D-TWIN");
  EXPECT_EQ(f.index, 5);
  EXPECT_EQ(f.flags, 0u) << FrameFlagNames(f.flags);
  double sq = 0;
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(f.valid[i]) << i;
    sq += (f.displacements_mm[i] - Eigen::Vector3d(d_true[i], d_true[n + i], d_true[2 * n + i])).squaredNorm();
  }
  const double displacement_rmse = std::sqrt(sq / n);
  const Eigen::Vector3d total(f_true.segment(0, n).sum(), f_true.segment(n, n).sum(), f_true.segment(2 * n, n).sum());
  std::printf("displacement RMSE %.4f mm; resultant %s N, true %s N\n", displacement_rmse,
              ::testing::PrintToString(f.resultant_force_n.transpose()).c_str(),
              ::testing::PrintToString(total.transpose()).c_str());
  EXPECT_LT(displacement_rmse, 0.01);
  // Measured 0.24% of |F| (2026-11-24); 1% leaves room for noise, not for a broken inverse.
  EXPECT_LT((f.resultant_force_n - total).norm(), 0.01 * total.norm());
  // The contact markers surround the press; the normals point out of the body.
  int contact = 0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double weight = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_GT(f.normals[i].z(), 0.5);
    EXPECT_NEAR(f.normals[i].norm(), 1.0, 1e-9);
    if (!f.contact[i]) continue;
    ++contact;
    const double fz = -f.forces_n[i].z();
    centroid += fz * rest[i].head<2>();
    weight += fz;
  }
  EXPECT_GT(contact, 4);
  EXPECT_LT((centroid / weight - Eigen::Vector2d(2, -1)).norm(), 0.5);
}

TEST(Pipeline, ZeroingTakesANewReference) {
  TwinStream run(FiveReferenceFrames());
  std::vector<Eigen::Vector3d> markers = Sensor().MarkerPositions();
  for (int k = 0; k < 5; ++k) run.Step(markers);
  // A drift of 0.05 mm along x, then zeroing: after five frames the displacements are ~0 again.
  for (auto& p : markers) p.x() += 0.05;
  const TactileFrame drifted = run.Step(markers);
  EXPECT_NEAR(drifted.displacements_mm[210].x(), 0.05, 0.01);
  run.pipeline.RequestZero();
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(run.Step(markers).has(FrameFlag::kInitializing));
  const TactileFrame zeroed = run.Step(markers);
  EXPECT_TRUE(zeroed.has(FrameFlag::kZeroed));
  EXPECT_NEAR(zeroed.displacements_mm[210].x(), 0.0, 0.01);
  EXPECT_FALSE(run.Step(markers).has(FrameFlag::kZeroed));
}

TEST(Pipeline, BlackFramesAreFlaggedNeverCrashOrGiveNaNForces) {
  TwinStream run(FiveReferenceFrames());
  const cv::Mat black(480, 640, CV_8UC1, cv::Scalar(0));
  // A covered camera at start: no reference is taken from it.
  for (int k = 0; k < 7; ++k) {
    const TactileFrame f = run.StepImage(black);
    EXPECT_TRUE(f.has(FrameFlag::kInitializing));
    EXPECT_TRUE(f.has(FrameFlag::kMarkersLost));
  }
  const std::vector<Eigen::Vector3d> rest = Sensor().MarkerPositions();
  for (int k = 0; k < 5; ++k) run.Step(rest);
  EXPECT_FALSE(run.Step(rest).has(FrameFlag::kInitializing));
  // A black frame while running: every marker lost, forces finite.
  const TactileFrame lost = run.StepImage(black);
  EXPECT_TRUE(lost.has(FrameFlag::kMarkersLost));
  for (int i = 0; i < lost.num_markers(); ++i) {
    EXPECT_FALSE(lost.valid[i]);
    EXPECT_TRUE(lost.forces_n[i].allFinite());
  }
  // The next good frame is measured again (the grid re-acquired).
  const TactileFrame back = run.Step(rest);
  EXPECT_TRUE(back.has(FrameFlag::kGridReacquired));
  EXPECT_FALSE(back.has(FrameFlag::kMarkersLost));
}

TEST(Pipeline, LargeDisplacementIsFlaggedOutOfRange) {
  PipelineOptions options = FiveReferenceFrames();
  options.displacement_range_mm = 0.2;
  TwinStream run(options);
  std::vector<Eigen::Vector3d> markers = Sensor().MarkerPositions();
  for (int k = 0; k < 5; ++k) run.Step(markers);
  for (auto& p : markers) p.x() += 0.3;
  EXPECT_TRUE(run.Step(markers).has(FrameFlag::kDisplacementOutOfRange));
}

TEST(Pipeline, BadInputAndMismatchedModelsAreErrors) {
  TwinStream run(FiveReferenceFrames());
  TactileFrame out;
  EXPECT_THROW(run.pipeline.Process(Frame{cv::Mat(100, 100, CV_8UC1), 0, 0}, out), Error);
  EXPECT_THROW(run.pipeline.Process(Frame{}, out), Error);
  std::vector<Eigen::Vector3d> elsewhere = Sensor().MarkerPositions();
  elsewhere[7].z() += 0.1;
  EXPECT_THROW(Pipeline(Sensor(), H(), elsewhere), Error);
  PipelineOptions bad;
  bad.reference_frames = 1;
  EXPECT_THROW(Pipeline(Sensor(), H(), Sensor().MarkerPositions(), bad), Error);
}

}  // namespace
}  // namespace tac3d

namespace tac3d {
namespace {

// Hertz pressure over radius 4 mm about (1, 0) mm, 3 N in all, with a tangential traction of
// mu_x times the pressure: Coulomb saturation everywhere, i.e. gross slip along +x.
Eigen::VectorXd SlidingForces(double mu_x) {
  const std::vector<Eigen::Vector3d> markers = Sensor().MarkerPositions();
  const int n = static_cast<int>(markers.size());
  Eigen::VectorXd p(n);
  for (int i = 0; i < n; ++i) {
    const double rho2 = (markers[i].head<2>() - Eigen::Vector2d(1, 0)).squaredNorm() / 16.0;
    p[i] = rho2 < 1 ? std::sqrt(1 - rho2) : 0.0;
  }
  p *= 3.0 / p.sum();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  f.segment(0, n) = mu_x * p;
  f.segment(2 * n, n) = -p;
  return f;
}

TEST(Pipeline, EveryFrameCarriesTheSlipStateAndGrossSlipsMu) {
  TwinStream run(FiveReferenceFrames());
  const std::vector<Eigen::Vector3d> rest = Sensor().MarkerPositions();
  for (int k = 0; k < 5; ++k) {
    const TactileFrame f = run.Step(rest);
    EXPECT_EQ(f.slip.state, SlipState::kNone) << k;  // initialising, then no contact
    EXPECT_TRUE(std::isnan(f.slip.friction));
  }
  constexpr double kMu = 0.4;
  const Eigen::VectorXd d = H() * SlidingForces(kMu);
  const int n = static_cast<int>(rest.size());
  std::vector<Eigen::Vector3d> pressed = rest;
  for (int i = 0; i < n; ++i) pressed[i] += Eigen::Vector3d(d[i], d[n + i], d[2 * n + i]);
  // Steady sliding: the same deformation frame after frame.
  for (int k = 0; k < 3; ++k) {
    const TactileFrame f = run.Step(pressed);
    std::printf("slip %s fraction %.3f mu %.4f +- %.4f (true %.2f)\n", SlipStateName(f.slip.state),
                f.slip.fraction, f.slip.friction, f.slip.friction_sigma, kMu);
    EXPECT_EQ(f.slip.state, SlipState::kGrossSlip) << f.slip.fraction;
    EXPECT_NEAR(f.slip.friction, kMu, 0.05);
    EXPECT_GT(f.slip.friction_sigma, 0.0);
  }
  EXPECT_EQ(run.Step(rest).slip.state, SlipState::kNone);
}

}  // namespace
}  // namespace tac3d
