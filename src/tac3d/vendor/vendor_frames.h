#pragma once

#include <string>
#include <vector>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/vendor/vendor_recording.h"

namespace tac3d {

/// A vendor recording's frames as TactileFrames (docs/real-sensors.md): the marker grid is taken
/// square (400 markers: 20 x 20, as every Tac3D's); the vendor's fields are carried bit for bit
/// (positions, displacements, forces, resultant force and moment, index, sendTimestamp as
/// timestamp_s); what the vendor does not record is absent: normals are zero vectors, every
/// marker valid and out of contact, the slip state unknown, initialize_progress 100.
/// @throws Error if the marker count is not a square of 1 .. TactileFrame::kMaxGridSide.
std::vector<TactileFrame> FramesOfVendorRecording(const VendorRecording& recording);

/// The vendor recording of TactileFrames (the inverse of FramesOfVendorRecording for the
/// vendor's fields): serial number of the first frame.
/// @throws Error if there is no frame, or the frames' serial number or grid changes.
VendorRecording VendorRecordingOfFrames(const std::vector<TactileFrame>& frames);

}  // namespace tac3d
