#include "tac3d/pipeline/drift_monitor.h"

#include <algorithm>
#include <cmath>

#include "tac3d/util/error.h"

namespace tac3d {

void DriftOptions::Validate() const {
  const OptionCheck require("drift");
  require(mode == DriftMode::kOff || mode == DriftMode::kFlag || mode == DriftMode::kRezero,
          "mode",
          "off, flag or rezero",
          static_cast<int>(mode));
  require(time_constant_s > 0 && std::isfinite(time_constant_s),
          "time_constant_s",
          "> 0 and finite",
          time_constant_s);
  require(rest_band_mm > 0, "rest_band_mm", "> 0", rest_band_mm);
  require(flag_mm > 0, "flag_mm", "> 0", flag_mm);
}

DriftMonitor::DriftMonitor(const DriftOptions& options) : options_((options.Validate(), options)) {}

void DriftMonitor::Reset() {
  std::fill(drift_.begin(), drift_.end(), Eigen::Vector3d::Zero());
  has_last_ = false;
}

DriftStatus DriftMonitor::Update(double timestamp_s,
                                 MarkerField& field,
                                 DisplacementReference& reference) {
  if (options_.mode == DriftMode::kOff) return {};
  const std::size_t n = field.positions.size();
  if (drift_.size() != n) drift_.assign(n, Eigen::Vector3d::Zero());
  const double dt = has_last_ ? std::max(0.0, timestamp_s - last_timestamp_s_) : 0.0;
  last_timestamp_s_ = timestamp_s;
  has_last_ = true;

  std::size_t valid = 0;
  double max_displacement = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!field.valid[i]) continue;
    ++valid;
    max_displacement = std::max(max_displacement, field.displacements[i].norm());
  }
  DriftStatus status;
  status.at_rest = 2 * valid >= n && valid > 0 && max_displacement <= options_.rest_band_mm;
  if (status.at_rest && dt > 0) {
    const double alpha = 1.0 - std::exp(-dt / options_.time_constant_s);
    for (std::size_t i = 0; i < n; ++i) {
      if (!field.valid[i]) continue;
      if (options_.mode == DriftMode::kFlag) {
        drift_[i] += alpha * (field.displacements[i] - drift_[i]);
      } else {
        const Eigen::Vector3d step = alpha * field.displacements[i];
        reference.Shift(i, step);
        field.displacements[i] -= step;
        drift_[i] += step;
      }
    }
  }
  double sum2 = 0.0;
  for (const Eigen::Vector3d& d : drift_) sum2 += d.squaredNorm();
  status.drift_rms_mm = n > 0 ? std::sqrt(sum2 / n) : 0.0;
  status.flagged = status.drift_rms_mm > options_.flag_mm;
  return status;
}

}  // namespace tac3d
