#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "tac3d/stereo/refraction_compensation.h"
#include "tac3d/stereo/stereo_rig.h"

namespace tac3d {

/// How stereo accounts for the glass and silicone between the cameras and the markers.
enum class RefractionModel {
  kNone,        ///< triangulate as if through air (for comparison only)
  kPolynomial,  ///< the paper's fitted polynomial correction (default, fast)
  kExact,       ///< reprojection through the flat layers (reference, slow)
};

/// The 3D markers of one frame, row-major over the grid (sensor frame, mm).
struct MarkerField {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> displacements;  ///< position - reference; zero without one
  std::vector<std::uint8_t> valid;             ///< 0: lost, mismatched or not measured

  int CountValid() const;
};

struct MarkerTriangulatorOptions {
  RefractionModel model = RefractionModel::kPolynomial;
  RefractionCompensationOptions compensation;
  /// A pair whose rays miss each other by more than this is a mismatch, not a marker.
  double max_ray_gap_mm = 0.15;

  void Validate() const;
};

/// Triangulates a frame's tracked markers (both halves' pixels, paired by index) into a
/// MarkerField: the seam between tracking and a sensor's camera model. A marker is valid only if
/// both halves saw it and its two rays agree. The twin's mirror rig is MarkerTriangulator; a
/// vendor's pinhole-and-refraction model is VendorMarkerTriangulator (vendor_formats/vendor_stereo.h).
class StereoTriangulator {
 public:
  virtual ~StereoTriangulator() = default;

  /// @param left, right pixel centroids per marker (NaN when the tracker lost it).
  /// @param out resized on the first call only; `displacements` are left untouched.
  /// @throws Error if the two halves' counts differ from the grid's.
  void Triangulate(const std::vector<Eigen::Vector2d>& left, const std::vector<Eigen::Vector2d>& right,
                   MarkerField& out) const;

 protected:
  explicit StereoTriangulator(int markers) : markers_(markers) {}
  /// One marker from its pixels in both halves (finite); nullopt if they do not make one.
  virtual std::optional<Eigen::Vector3d> TriangulateMarker(const Eigen::Vector2d& left,
                                                           const Eigen::Vector2d& right) const = 0;

 private:
  int markers_;
};

/// The mirror rig's triangulation: the virtual cameras' straight rays, then the refraction
/// corrected (MarkerTriangulatorOptions::model).
class MarkerTriangulator : public StereoTriangulator {
 public:
  /// @param config a sensor with calibrated (or designed) virtual cameras.
  /// @throws Error if it has none, or if the options are invalid.
  MarkerTriangulator(const SensorConfig& config, const MarkerTriangulatorOptions& options = {});

  const StereoRig& rig() const { return rig_; }
  const std::optional<RefractionCompensation>& compensation() const { return compensation_; }

 private:
  std::optional<Eigen::Vector3d> TriangulateMarker(const Eigen::Vector2d& left,
                                                   const Eigen::Vector2d& right) const override;

  MarkerTriangulatorOptions options_;
  StereoRig rig_;
  std::optional<RefractionCompensation> compensation_;
};

/// The undeformed state markers are measured against (paper: displacement = position -
/// undeformed position). Set from a frame (or the mean of several static frames) and
/// re-set on request (`$C` zeroing).
class DisplacementReference {
 public:
  /// Takes the mean of the valid positions over the frames as the reference; a marker valid
  /// in none of them has no reference.
  void Set(const std::vector<MarkerField>& frames);
  bool empty() const { return reference_.empty(); }
  /// Fills `displacements`; a marker without a reference becomes invalid.
  void Apply(MarkerField& field) const;
  const std::vector<Eigen::Vector3d>& positions() const { return reference_; }
  /// Moves marker i's reference by delta_mm (the drift at rest tracked out,
  /// pipeline/drift_monitor.h). @pre i < positions().size().
  void Shift(std::size_t i, const Eigen::Vector3d& delta_mm);

 private:
  std::vector<Eigen::Vector3d> reference_;
  std::vector<std::uint8_t> known_;
};

}  // namespace tac3d
