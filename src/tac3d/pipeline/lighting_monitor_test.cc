#include "tac3d/pipeline/lighting_monitor.h"

#include <gtest/gtest.h>

#include <functional>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A 10 x 10 grid seen in both halves: every marker's background and contrast given by
// level(h, i) and contrast(h, i) (DN).
MarkerObservation Observation(const std::function<double(int, int)>& level,
                              const std::function<double(int, int)>& contrast) {
  MarkerObservation o;
  o.rows = o.cols = 10;
  for (int h = 0; h < 2; ++h) {
    HalfObservation& half = o.halves[h];
    half.uv.assign(100, Eigen::Vector2d::Zero());
    half.state.assign(100, MarkerState::kValid);
    half.background_dn.resize(100);
    half.contrast_dn.resize(100);
    for (int i = 0; i < 100; ++i) {
      half.background_dn[i] = level(h, i);
      half.contrast_dn[i] = contrast(h, i);
    }
  }
  return o;
}

// Reference levels: 200 DN film, 150 DN contrast, varying a little from marker to marker.
double Level(int h, int i) { return 190.0 + (i * 7 + h * 3) % 20; }
double Contrast(int h, int i) { return 140.0 + (i * 11 + h) % 20; }

LightingMonitor WithReference(const LightingMonitorOptions& options = {}) {
  LightingMonitor monitor(options);
  for (int k = 0; k < 3; ++k) monitor.AddReference(Observation(Level, Contrast));
  monitor.FinishReference();
  return monitor;
}

TEST(LightingMonitor, TheReferenceLightingIsNotAChange) {
  LightingMonitor monitor = WithReference();
  const LightingChange c = monitor.Compare(Observation(Level, Contrast));
  EXPECT_DOUBLE_EQ(c.contrast_ratio, 1.0);
  EXPECT_DOUBLE_EQ(c.level_ratio, 1.0);
  EXPECT_FALSE(c.changed);
}

TEST(LightingMonitor, ADimmingStepIsFlaggedAndASmallOneOrABrighterOneIsNot) {
  LightingMonitor monitor = WithReference();
  auto scaled = [](double gain) {
    return Observation([gain](int h, int i) { return gain * Level(h, i); },
                       [gain](int h, int i) { return gain * Contrast(h, i); });
  };
  const LightingChange dim = monitor.Compare(scaled(0.6));
  EXPECT_NEAR(dim.contrast_ratio, 0.6, 1e-12);
  EXPECT_NEAR(dim.level_ratio, 0.6, 1e-12);
  EXPECT_TRUE(dim.changed);
  EXPECT_FALSE(monitor.Compare(scaled(0.85)).changed);
  EXPECT_FALSE(monitor.Compare(scaled(1.35)).changed);  // more contrast does not hurt
}

TEST(LightingMonitor, FadedMarkersAreFlaggedBelowTheContrastRatio) {
  LightingMonitor monitor = WithReference();
  auto faded = [](double fraction) {
    return Observation(Level, [fraction](int h, int i) { return fraction * Contrast(h, i); });
  };
  EXPECT_FALSE(monitor.Compare(faded(0.75)).changed);
  const LightingChange c = monitor.Compare(faded(0.65));
  EXPECT_NEAR(c.contrast_ratio, 0.65, 1e-12);
  EXPECT_NEAR(c.level_ratio, 1.0, 1e-12);
  EXPECT_TRUE(c.changed);
}

TEST(LightingMonitor, ADimmedSideIsFlaggedThoughTheMedianHolds) {
  LightingMonitor monitor = WithReference();
  // The left half's light at 60%, the right half's at 100%: the median ratio is 0.8.
  auto side = [](double left) {
    return Observation([left](int h, int i) { return (h == 0 ? left : 1.0) * Level(h, i); },
                       [left](int h, int i) { return (h == 0 ? left : 1.0) * Contrast(h, i); });
  };
  const LightingChange c = monitor.Compare(side(0.6));
  EXPECT_NEAR(c.contrast_ratio, 0.6, 1e-12);
  EXPECT_TRUE(c.changed);
  LightingMonitor median = WithReference({.quantile = 0.5});
  EXPECT_FALSE(median.Compare(side(0.6)).changed);
}

TEST(LightingMonitor, NoReferenceOrDisabledNeverFlags) {
  LightingMonitor fresh;
  const MarkerObservation dark =
      Observation([](int, int) { return 50.0; }, [](int, int) { return 30.0; });
  EXPECT_FALSE(fresh.Compare(dark).changed);
  LightingMonitor disabled = WithReference({.enabled = false});
  EXPECT_FALSE(disabled.Compare(dark).changed);
  LightingMonitor cleared = WithReference();
  cleared.ClearReference();
  EXPECT_FALSE(cleared.Compare(dark).changed);
}

TEST(LightingMonitor, LostMarkersAreLeftOut) {
  LightingMonitor monitor = WithReference();
  MarkerObservation o = Observation(Level, Contrast);
  for (int i = 0; i < 40; ++i) {  // the lost markers' levels are not read
    o.halves[0].state[i] = MarkerState::kNotFound;
    o.halves[0].background_dn[i] = o.halves[0].contrast_dn[i] = 0.0;
  }
  EXPECT_FALSE(monitor.Compare(o).changed);
}

TEST(LightingMonitor, OptionsOutOfRangeThrow) {
  EXPECT_THROW(LightingMonitor({.min_contrast_ratio = 1.0}), Error);
  EXPECT_THROW(LightingMonitor({.quantile = 0.6}), Error);
}

}  // namespace
}  // namespace tac3d
