#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/force/force_reconstructor.h"
#include "tac3d/force/marker_surface.h"
#include "tac3d/frame/tactile_frame.h"
#include "tac3d/pipeline/drift_monitor.h"
#include "tac3d/pipeline/lighting_monitor.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/slip/slip_estimator.h"
#include "tac3d/source/frame_source.h"
#include "tac3d/stereo/marker_field.h"
#include "tac3d/tracking/marker_tracker.h"

namespace tac3d {

struct PipelineOptions {
  std::string sn = "TAC3D-TWIN";
  /// Static frames averaged into the reference (the undeformed state) at start and after
  /// a zeroing request; the displacement noise is estimated from them too.
  int reference_frames = 20;
  /// The inverse's weight w, gains and contact-support re-solve: the built-in prototype's
  /// defaults here; DefaultPipelineOptions gives each sensor its own.
  ForceReconstructorOptions force = {.weight = 0.05, .gains = Eigen::Vector3d::Ones()};
  ContactOptions contact;
  /// The contact's slip state and friction estimate (docs/slip.md); its force and
  /// displacement noise are replaced by the measured ones after each reference.
  SlipOptions slip;
  MarkerTrackerOptions tracking;
  /// The mirror model's triangulation; a vendor camera model uses only its max_ray_gap_mm.
  MarkerTriangulatorOptions stereo;
  /// A frame is flagged when a valid marker moved farther than this from its reference (mm),
  /// or the resultant force exceeds this (N): beyond what the sensor was built and calibrated
  /// for, so the numbers are not to be trusted.
  double displacement_range_mm = 3.0;
  double force_range_n = 30.0;
  /// kLightingChanged: the markers' lighting against the reference's.
  LightingMonitorOptions lighting;
  /// kDriftAtRest: the markers' drift at rest, flagged or tracked out of the reference.
  DriftOptions drift;

  /// @throws Error naming the field and its bound.
  void Validate() const;
};

/// The rest markers a compliance model of the sensor must have been built for: the mirror model's
/// nominal grid (SensorConfig::MarkerPositions), or a vendor model's reference pixels triangulated
/// (VendorStereo::TriangulateReference: the real markers, in the vendor's order, row 0 at +y and
/// column 0 at +x for HDL1-0001).
std::vector<Eigen::Vector3d> RestMarkerPositions(const SensorConfig& config);

/// The inverse a sensor runs with unless told otherwise.
/// - The built-in prototype (a mirror model): w = 0.05 (mm/N)^2, what the discrepancy principle
///   chose for 0.005 mm displacement noise on its twin, and the contact-support re-solve, tuned
///   on that twin (docs/force.md).
/// - An imported sensor (a vendor camera model): the paper's F = K D alone, without the re-solve
///   (tuned on the prototype's twin, it reads a real gel high), at the same w: the inverse
///   `tac3d eval vendor` checks against the vendor's recorded resultant (docs/real-sensors.md).
ForceReconstructorOptions DefaultForceOptions(const SensorConfig& config);

/// PipelineOptions with the sensor's serial number (DefaultSerialNumber) and inverse
/// (DefaultForceOptions).
PipelineOptions DefaultPipelineOptions(const SensorConfig& config);

/// The serial number a sensor's frames carry when none is given: an imported sensor's own
/// (camera_model.serial_number), else PipelineOptions' default.
std::string DefaultSerialNumber(const SensorConfig& config);

/// The per-frame chain of the paper (section IV): tracking -> 3D markers -> displacement ->
/// forces (F = K D) -> normals -> contact -> resultants, as one TactileFrame per image, and
/// beyond the paper the contact's slip state and friction coefficient (SlipEstimator).
/// The first `reference_frames` frames (and those after RequestZero) build the reference:
/// their TactileFrames carry initialize_progress < 100, the kInitializing flag and zero
/// displacements and forces. One instance per sensor stream; not thread-safe.
class Pipeline {
 public:
  /// @param config the sensor: calibrated virtual cameras (the twin's mirror model) or a
  ///   vendor camera model (`tac3d import-vendor`), and its markers.
  /// @param h the compliance H (3N x 3N) of the sensor's FEM and its rest marker positions:
  ///   RestMarkerPositions(config). Shared, not copied: the pipelines of one H object and weight
  ///   share the inverse's matrices (ForceReconstructor, ~50 MB with H for 400 markers); only
  ///   the per-frame state is each pipeline's own.
  /// @throws Error if the options are invalid or the sensor, H and grid disagree.
  Pipeline(const SensorConfig& config, const std::shared_ptr<const Eigen::MatrixXd>& h,
           const std::vector<Eigen::Vector3d>& fem_markers_mm, const PipelineOptions& options = {});
  /// The same with a copy of h, shared with no other pipeline.
  Pipeline(const SensorConfig& config, const Eigen::MatrixXd& h,
           const std::vector<Eigen::Vector3d>& fem_markers_mm, const PipelineOptions& options = {});
  ~Pipeline();

  /// Processes one camera image into `out` (its storage reused). A frame the tracker cannot
  /// measure (no grid) still gives a TactileFrame, every marker invalid and flagged. Of a partly
  /// decoded image (Frame::decoded_region) only that part is read.
  /// @throws Error if the timestamp is not finite (the frame could not be recorded or sent),
  ///   or the image is empty or not the camera's size and type.
  void Process(const Frame& frame, TactileFrame& out);

  /// Recomputes a recorded frame's forces, normals, contact, resultants and slip from its
  /// markers (valid, positions_mm, displacements_mm) through this pipeline's inverse, in place:
  /// to re-process a recording after a recalibration, or one of the vendor's software. The
  /// force and displacement range flags are set anew; the other flags are kept.
  /// @throws Error if the frame has another number of markers than the sensor, or a valid
  ///   marker's position or displacement is not finite.
  void RecomputeForces(TactileFrame& frame);

  /// The part of the next camera image Process reads (MarkerTracker::CalcReadRegion), for a
  /// source that can decode no more (FrameSource::SetDecodeRegion); nullopt: all of it.
  std::optional<cv::Rect> CalcReadRegion() const { return tracker_.CalcReadRegion(); }

  /// The tracker's markers in the image the last Process call was given (both halves' pixels,
  /// states and estimates): for a caller that draws them (the viewer), read after Process and
  /// valid until the next call; no copy is made for it.
  const MarkerObservation& observation() const { return observation_; }
  /// The inverse's output of the last Process or RecomputeForces call (whether the re-solve
  /// ran, on how many markers); valid until the next call.
  const ForceFrame& force_frame() const { return force_; }

  /// Takes the next reference_frames frames as the new reference (`$C`).
  void RequestZero();
  bool initializing() const;
  /// The displacement noise variance (mm^2, per axis) measured on the last reference.
  const std::optional<Eigen::Vector3d>& noise_variance() const { return noise_variance_; }
  const PipelineOptions& options() const { return options_; }
  /// The inverse's matrices (H, K, ...), shared with the other pipelines of the same H and weight.
  const TikhonovInverse& inverse() const { return *reconstructor_.inverse(); }

 private:
  // A frame while the reference is being taken: markers as measured, no forces.
  void FillInitializing(int progress, TactileFrame& out) const;
  // Forces, normals, contact, resultants, range flags and slip of `out` from d_ and valid_ (the
  // positions and displacements already in `out`).
  void ComputeForces(TactileFrame& out);
  // Adds this frame to the reference being taken; true once it is complete (else `out` is
  // an initializing frame).
  bool CollectReference(TactileFrame& out);

  PipelineOptions options_;
  int rows_, cols_;
  MarkerTracker tracker_;
  std::unique_ptr<StereoTriangulator> triangulator_;
  ForceReconstructor reconstructor_;
  MarkerSurface surface_;
  SlipEstimator slip_;
  LightingMonitor lighting_;
  DriftMonitor drift_;
  DisplacementReference reference_;
  std::vector<MarkerField> reference_stack_;
  std::optional<Eigen::Vector3d> noise_variance_;
  bool zero_requested_ = false;
  std::int64_t frames_ = 0;
  // Per-frame scratch.
  MarkerObservation observation_;
  MarkerField field_;
  Eigen::VectorXd d_;
  std::vector<bool> valid_;
  ForceFrame force_;
};

}  // namespace tac3d
