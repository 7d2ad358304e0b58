#include "tac3d/pipeline/drift_monitor.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr int kMarkers = 25;
constexpr double kFrameS = 0.1;

// Markers at rest with a reference taken at zero, then moved uniformly by offset(t).
struct Stream {
  MarkerField field;
  DisplacementReference reference;
  DriftMonitor monitor;

  explicit Stream(const DriftOptions& options) : monitor(options) {
    field.positions.assign(kMarkers, Eigen::Vector3d::Zero());
    field.displacements.assign(kMarkers, Eigen::Vector3d::Zero());
    field.valid.assign(kMarkers, 1);
    reference.Set({field});
  }
  DriftStatus Step(double t_s, const Eigen::Vector3d& offset) {
    for (auto& p : field.positions) p = offset;
    reference.Apply(field);
    return monitor.Update(t_s, field, reference);
  }
};

// The first time (s) the flag is raised for a drift of `rate` mm/s along -z, or -1.
double FirstFlag(Stream& s, double rate, double until_s) {
  for (int k = 0; k * kFrameS <= until_s; ++k) {
    const double t = k * kFrameS;
    if (s.Step(t, Eigen::Vector3d(0, 0, -rate * t)).flagged) return t;
  }
  return -1;
}

TEST(DriftMonitor, ASteadyDriftIsFlaggedWithinTheTimeConstantOfPassingTheThreshold) {
  const DriftOptions options;  // flag mode, 10 s, 0.01 mm
  Stream s(options);
  const double rate = 0.0005;  // mm/s: 0.01 mm after 20 s
  const double crossing = options.flag_mm / rate;
  const double flagged = FirstFlag(s, rate, 100);
  // The low pass lags a ramp by its time constant: flagged after the crossing, within tau.
  EXPECT_GT(flagged, crossing);
  EXPECT_LE(flagged, crossing + options.time_constant_s);
  // Flag mode leaves the data alone.
  EXPECT_NEAR(s.field.displacements[0].z(), -rate * flagged, 1e-12);
}

TEST(DriftMonitor, RezeroTracksADriftOutOfTheDisplacements) {
  DriftOptions options;
  options.mode = DriftMode::kRezero;
  Stream s(options);
  const double rate = 0.0005;
  DriftStatus status;
  for (int k = 0; k * kFrameS <= 120; ++k)
    status = s.Step(k * kFrameS, Eigen::Vector3d(0, 0, -rate * k * kFrameS));
  // The residual is the lag, rate x tau (0.005 mm), not the 0.06 mm drifted.
  EXPECT_NEAR(s.field.displacements[0].z(), -rate * options.time_constant_s, 2e-4);
  EXPECT_NEAR(s.reference.positions()[0].z(), -rate * (120 - options.time_constant_s), 2e-4);
  EXPECT_TRUE(status.at_rest);
  EXPECT_TRUE(status.flagged);  // the reference moved more than 0.01 mm
}

TEST(DriftMonitor, ALoadBeyondTheRestBandIsNeverTakenForDrift) {
  for (DriftMode mode : {DriftMode::kFlag, DriftMode::kRezero}) {
    DriftOptions options;
    options.mode = mode;
    Stream s(options);
    const Eigen::Vector3d press(0, 0, -0.06);  // just beyond the 0.05 mm band, held 100 s
    for (int k = 0; k < 1000; ++k) {
      const DriftStatus status = s.Step(k * kFrameS, press);
      EXPECT_FALSE(status.at_rest);
      EXPECT_FALSE(status.flagged);
    }
    EXPECT_EQ(s.field.displacements[0], press);
    EXPECT_EQ(s.monitor.drift_mm()[0], Eigen::Vector3d::Zero());
  }
}

TEST(DriftMonitor, ResetForgetsTheDriftAndOffDoesNothing) {
  Stream s({});
  EXPECT_GT(FirstFlag(s, 0.001, 100), 0);
  s.monitor.Reset();
  EXPECT_FALSE(s.Step(200, Eigen::Vector3d::Zero()).flagged);

  DriftOptions off;
  off.mode = DriftMode::kOff;
  Stream none(off);
  EXPECT_LT(FirstFlag(none, 0.001, 100), 0);
}

TEST(DriftMonitor, TooFewValidMarkersIsNotRest) {
  Stream s({});
  for (int i = 0; i < 13; ++i) s.field.valid[i] = 0;
  EXPECT_FALSE(s.Step(0, Eigen::Vector3d::Zero()).at_rest);
}

TEST(DriftMonitor, OptionsOutOfRangeThrow) {
  EXPECT_THROW(DriftMonitor({.time_constant_s = 0}), Error);
  EXPECT_THROW(DriftMonitor({.rest_band_mm = 0}), Error);
  EXPECT_THROW(DriftMonitor({.flag_mm = -1}), Error);
}

}  // namespace
}  // namespace tac3d
