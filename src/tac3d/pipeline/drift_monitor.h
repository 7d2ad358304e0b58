#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "tac3d/stereo/marker_field.h"

namespace tac3d {

/// What the pipeline does about a slow drift of the markers at rest (the gel creeping, a
/// temperature change): the vendor's `$C` re-zeroes by hand; this watches for it.
enum class DriftMode : std::uint8_t {
  kOff,
  kFlag,    ///< estimate the drift and flag it (FrameFlag::kDriftAtRest); data untouched
  kRezero,  ///< track it out of the reference at rest (zero tracking, as a scale's), and flag
};

/// Drift at rest: like a weighing scale's automatic zero tracking (OIML R 76-1), the
/// reference may only follow the markers while they are near it; a larger displacement is
/// a load, never taken for drift. docs/pipeline.md, "Lighting and drift".
struct DriftOptions {
  DriftMode mode = DriftMode::kFlag;
  /// Each marker's drift estimate is its displacement low-passed at rest, exponentially
  /// with this time constant (s). A drift growing steadily is flagged at most this long
  /// after it passes flag_mm; in kRezero the displacements lag a steady drift by its rate
  /// times this.
  double time_constant_s = 10.0;
  /// At rest: at least half the markers valid and every valid one within this of its
  /// reference (mm). A touch held below it is taken for drift too (as on a scale).
  double rest_band_mm = 0.05;
  /// Flag when the drift estimate's RMS over the markers exceeds this (mm): in kFlag the
  /// displacements carry it, in kRezero the reference has moved that far since it was taken.
  double flag_mm = 0.01;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

struct DriftStatus {
  bool at_rest = false;
  double drift_rms_mm = 0.0;  ///< RMS over the markers of the drift estimate
  bool flagged = false;       ///< drift_rms_mm > flag_mm
};

/// Estimates the drift of each marker at rest (DriftOptions) from frame to frame.
class DriftMonitor {
 public:
  explicit DriftMonitor(const DriftOptions& options = {});

  /// A new reference: no drift yet.
  void Reset();
  /// One frame whose displacements are applied: updates the estimate if at rest; in kRezero
  /// moves the reference by this frame's share of the drift and the displacements with it.
  /// @param timestamp_s the frame's time (s); the low pass uses the time between frames.
  DriftStatus Update(double timestamp_s, MarkerField& field, DisplacementReference& reference);
  /// Per marker, the drift estimate (mm, sensor frame).
  const std::vector<Eigen::Vector3d>& drift_mm() const { return drift_; }

 private:
  DriftOptions options_;
  std::vector<Eigen::Vector3d> drift_;
  double last_timestamp_s_ = 0.0;
  bool has_last_ = false;
};

}  // namespace tac3d
