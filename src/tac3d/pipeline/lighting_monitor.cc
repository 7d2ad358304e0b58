#include "tac3d/pipeline/lighting_monitor.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A figure that could not be measured (no marker, no reference).
constexpr double kUnmeasured = std::numeric_limits<double>::quiet_NaN();

// The value at fraction q (0..1) of `values` by rank (reorders them); NaN if empty.
double Quantile(std::vector<double>& values, double q) {
  if (values.empty()) return kUnmeasured;
  const auto k = static_cast<std::ptrdiff_t>(std::lround(q * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

}  // namespace

void LightingMonitorOptions::Validate() const {
  const OptionCheck require("lighting monitor");
  require(min_contrast_ratio > 0 && min_contrast_ratio < 1,
          "min_contrast_ratio",
          "in (0, 1)",
          min_contrast_ratio);
  require(quantile >= 0 && quantile <= 0.5, "quantile", "in [0, 0.5]", quantile);
}

LightingMonitor::LightingMonitor(const LightingMonitorOptions& options)
    : options_((options.Validate(), options)) {}

void LightingMonitor::ClearReference() {
  has_reference_ = false;
  std::fill(background_.begin(), background_.end(), 0.0);
  std::fill(contrast_.begin(), contrast_.end(), 0.0);
  std::fill(count_.begin(), count_.end(), 0);
}

void LightingMonitor::AddReference(const MarkerObservation& observation) {
  const std::size_t n = static_cast<std::size_t>(observation.rows) * observation.cols;
  if (count_.size() != 2 * n) {
    background_.assign(2 * n, 0.0);
    contrast_.assign(2 * n, 0.0);
    count_.assign(2 * n, 0);
  }
  for (int h = 0; h < 2; ++h) {
    const HalfObservation& half = observation.halves[h];
    for (std::size_t i = 0; i < n; ++i) {
      if (!half.valid(static_cast<int>(i))) continue;
      background_[h * n + i] += half.background_dn[i];
      contrast_[h * n + i] += half.contrast_dn[i];
      ++count_[h * n + i];
    }
  }
}

void LightingMonitor::FinishReference() {
  for (std::size_t k = 0; k < count_.size(); ++k) {
    background_[k] = count_[k] > 0 ? background_[k] / count_[k] : kUnmeasured;
    contrast_[k] = count_[k] > 0 ? contrast_[k] / count_[k] : kUnmeasured;
  }
  has_reference_ = !count_.empty();
}

LightingChange LightingMonitor::Compare(const MarkerObservation& observation) {
  const std::size_t n = static_cast<std::size_t>(observation.rows) * observation.cols;
  if (!has_reference_ || count_.size() != 2 * n) return {kUnmeasured, kUnmeasured, false};
  level_ratios_.clear();
  contrast_ratios_.clear();
  for (int h = 0; h < 2; ++h) {
    const HalfObservation& half = observation.halves[h];
    for (std::size_t i = 0; i < n; ++i) {
      if (!half.valid(static_cast<int>(i)) || count_[h * n + i] == 0) continue;
      level_ratios_.push_back(half.background_dn[i] / background_[h * n + i]);
      contrast_ratios_.push_back(half.contrast_dn[i] / contrast_[h * n + i]);
    }
  }
  LightingChange c;
  c.contrast_ratio = Quantile(contrast_ratios_, options_.quantile);
  c.level_ratio = Quantile(level_ratios_, 0.5);
  // Without a valid marker there is nothing to judge the lighting by (a covered camera:
  // the tracker's flags say so).
  c.changed = options_.enabled && !contrast_ratios_.empty() &&
              c.contrast_ratio < options_.min_contrast_ratio;
  return c;
}

}  // namespace tac3d
