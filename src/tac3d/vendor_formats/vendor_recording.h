#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/io/npy.h"

namespace tac3d {

/// The fields every vendor recording holds, as `<field>.npy` in its `<SN>` folder
/// (Tac3D-Desktop and PyTac3D's recorder; docs/real-sensors.md).
inline constexpr std::array<const char*, 7> kVendorRecordingFields = {
    "3D_Positions", "3D_Displacements", "3D_Forces", "3D_ResultantForce",
    "3D_ResultantMoment", "index", "sendTimestamp"};

/// A vendor recording of one sensor: each field's array as stored (float64 frames x markers x 3
/// for positions, displacements (mm) and forces (N); frames x 1 x 3 for the resultant force (N)
/// and moment; int64 frame indices; float64 send times (s)). 3D_Normals and recvTimestamp,
/// which the recorder does not write, are absent.
struct VendorRecording {
  std::string serial_number;  ///< the `<SN>` folder's name
  NpyArray positions;
  NpyArray displacements;
  NpyArray forces;
  NpyArray resultant_force;
  NpyArray resultant_moment;
  NpyArray index;
  NpyArray send_timestamp;

  std::int64_t frames() const { return index.shape.empty() ? 0 : index.shape[0]; }
  std::int64_t markers() const { return positions.shape.size() == 3 ? positions.shape[1] : 0; }
  /// Frame `frame` of a frames x markers x 3 field, one row a marker.
  static Eigen::MatrixX3d Frame(const NpyArray& field, std::int64_t frame);
  /// The markers' reference positions the vendor's software used in a frame: 3D_Positions -
  /// 3D_Displacements (the vendor corrects its zero point while nothing touches the gel, so
  /// this drifts between frames).
  Eigen::MatrixX3d ReferencePositions(std::int64_t frame) const;
  /// The first marker of a frame whose position, displacement or force holds a NaN or an
  /// infinity (a marker the vendor's software lost, or a damaged file), or -1 if none.
  std::int64_t FirstNonFiniteMarker(std::int64_t frame) const;
  /// Whether marker i of one frame's fields (Frame of each) is finite in all three.
  static bool MarkerIsFinite(const Eigen::MatrixX3d& positions,
                             const Eigen::MatrixX3d& displacements,
                             const Eigen::MatrixX3d& forces,
                             Eigen::Index i) {
    return positions.row(i).allFinite() && displacements.row(i).allFinite() && forces.row(i).allFinite();
  }
  /// How many frames have a NaN or an infinity in their resultant force or moment (replayed as
  /// recorded: the vendor's resultant is not the sum of its per-marker forces, so none is made up).
  std::int64_t FramesWithNonFiniteResultant() const;
  /// How far the vendor's zero point moved over the recording: the largest distance of a
  /// marker's reference position (ReferencePositions) in a frame from its own in frame 0 (mm).
  double MaxReferenceShiftMm() const;

  bool operator==(const VendorRecording&) const = default;
};

/// The `<SN>` folders of a vendor recording, sorted: `folder` itself if it holds index.npy, else
/// each of its subfolders that does (a recording of several sensors has one each).
/// @throws Error if `folder` is no folder or holds no such folder.
std::vector<std::string> FindVendorRecordingFolders(const std::string& folder);

/// Reads one `<SN>` folder's recording (serial number: the folder's name).
/// @throws Error naming the file of a missing, malformed or truncated field, a field of another
///   dtype or shape than the others imply (frame counts that differ, markers x 2), or a
///   sendTimestamp that is NaN or infinite.
VendorRecording ReadVendorSensorFolder(const std::string& serial_folder);

/// Reads a vendor recording of one sensor: `folder` is the `<SN>` folder holding the .npy files,
/// or the recording folder holding exactly one such `<SN>` folder.
/// @throws Error as FindVendorRecordingFolders and ReadVendorSensorFolder do, or naming the
///   sensors of a folder that holds several.
VendorRecording ReadVendorRecording(const std::string& folder);

/// Every sensor's recording in `folder` (FindVendorRecordingFolders), in the order of their SNs.
/// @throws Error as ReadVendorSensorFolder does, naming the file.
std::vector<VendorRecording> ReadVendorRecordings(const std::string& folder);

/// Writes `recording` as `<folder>/<serial_number>/<field>.npy` and its overview.csv
/// (index,timestamp,FRx,FRy,FRz,MRx,MRy,MRz) as the vendor's recorder does; ReadVendorRecording
/// reads it back equal, bit for bit. `folder` is made if missing.
/// @throws Error if the recording is inconsistent or a file cannot be written.
void WriteVendorRecording(const VendorRecording& recording, const std::string& folder);

}  // namespace tac3d
