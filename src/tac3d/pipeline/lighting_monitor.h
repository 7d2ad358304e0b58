#pragma once

#include <vector>

#include "tac3d/tracking/marker_tracker.h"

namespace tac3d {

/// When a frame's lighting differs enough from the reference's to flag it
/// (FrameFlag::kLightingChanged). The tracker measures every marker against its own local
/// background, so a change of gain, offset or a gentle gradient moves no centroid; what
/// hurts is a lower contrast: a centroid's noise grows as the contrast falls, so the
/// displacement noise measured on the reference (Pipeline::noise_variance, used by the slip
/// estimate and the force uncertainty) no longer holds. Measured: docs/pipeline.md,
/// "Lighting and drift".
struct LightingMonitorOptions {
  bool enabled = true;
  /// Flag when the markers' contrast ratio (this frame / reference, per marker) at
  /// `quantile` falls below this. Measured on the twin: faded markers at 0.7 of their
  /// contrast give 1.48 x the displacement noise (its variance doubled).
  double min_contrast_ratio = 0.7;
  /// The markers' contrast ratios are judged at this quantile, so a dimmed side or corner
  /// counts, not only a change of the whole image.
  double quantile = 0.1;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// The lighting of one frame against the reference's (ratios per marker over the markers
/// valid in both; NaN without a reference or a valid marker).
struct LightingChange {
  double contrast_ratio = 1.0;  ///< at the options' quantile
  double level_ratio = 1.0;     ///< the median of the background ratios (the film's light)
  bool changed = false;         ///< contrast_ratio < min_contrast_ratio
};

/// The markers' background and contrast over the reference frames, and each frame's
/// against them (Pipeline: kLightingChanged). Allocates only when the grid size changes.
class LightingMonitor {
 public:
  explicit LightingMonitor(const LightingMonitorOptions& options = {});

  /// Forgets the reference being collected (and the one in use).
  void ClearReference();
  /// Adds a reference frame's markers (the mean over the frames is the reference).
  void AddReference(const MarkerObservation& observation);
  /// Ends the collection: the mean of the frames added is the reference from now on.
  void FinishReference();
  /// This frame against the reference; `changed` false while disabled or without one.
  LightingChange Compare(const MarkerObservation& observation);

 private:
  LightingMonitorOptions options_;
  bool has_reference_ = false;
  // Per marker of both halves (half-major): sums over the reference frames, then means.
  std::vector<double> background_, contrast_;
  std::vector<int> count_;
  std::vector<double> level_ratios_, contrast_ratios_;  // scratch
};

}  // namespace tac3d
