#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/force/marker_surface.h"
#include "tac3d/frame/tactile_frame.h"
#include "tac3d/vendor_formats/vendor_recording.h"

namespace tac3d {

/// A vendor recording's frames as TactileFrames, one at a time (docs/real-sensors.md): the
/// marker grid is taken square (400 markers: 20 x 20, as every Tac3D's); the vendor's fields are
/// carried bit for bit (positions, displacements, forces, resultant force and moment, index,
/// sendTimestamp as timestamp_s). What the vendor does not record is made as tac3d's pipeline
/// makes it: each marker's normal is that of the deformed marker grid (MarkerSurface, oriented
/// by frame 0's reference positions 3D_Positions - 3D_Displacements) and its contact is
/// -f.n > ContactOptions' threshold; every marker is valid, the slip state unknown,
/// initialize_progress 100. Where frame 0's reference is no grid surface (fewer than 2 x 2
/// markers, points on a line, NaN) normals are zero vectors and no marker is in contact.
class VendorFrames {
 public:
  /// @throws Error if the marker count is not a square of 1 .. TactileFrame::kMaxGridSide.
  explicit VendorFrames(VendorRecording recording);

  std::int64_t frames() const { return recording_.frames(); }
  /// Frame f's sendTimestamp (s). @pre 0 <= f < frames().
  double timestamp_s(std::int64_t f) const { return time_s_[f]; }
  const VendorRecording& recording() const { return recording_; }
  /// Whether normals and contact are computed (frame 0's reference is a grid surface).
  bool has_normals() const { return surface_.has_value(); }
  /// Frame `f`. @pre 0 <= f < frames().
  TactileFrame Frame(std::int64_t f) const;

 private:
  VendorRecording recording_;
  int side_ = 0;
  std::vector<std::int64_t> index_;
  std::vector<double> time_s_;
  Eigen::MatrixX3d reference_;  // frame 0's 3D_Positions - 3D_Displacements
  std::optional<MarkerSurface> surface_;
};

/// Every frame of a vendor recording (VendorFrames).
/// @throws Error as VendorFrames' constructor does.
std::vector<TactileFrame> FramesOfVendorRecording(const VendorRecording& recording);

/// The vendor recording of TactileFrames (the inverse of FramesOfVendorRecording for the
/// vendor's fields): serial number of the first frame.
/// @throws Error if there is no frame, or the frames' serial number or grid changes.
VendorRecording VendorRecordingOfFrames(const std::vector<TactileFrame>& frames);

}  // namespace tac3d
