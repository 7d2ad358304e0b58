#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tac3d/record/recording.h"

namespace tac3d {

enum class RecordingExportFormat {
  /// frames.csv (one row a frame) and markers.csv (one row a frame and marker).
  kCsv,
  /// One .npy array a field, frames along the first axis (RecordingNpyFiles()).
  kNpy,
};

/// @throws Error unless `name` is "csv" or "npy".
RecordingExportFormat ParseRecordingExportFormat(const std::string& name);

struct RecordingExportOptions {
  RecordingExportFormat format = RecordingExportFormat::kNpy;
  /// false: refuse to replace a file that is already in the output folder.
  bool overwrite = false;
};

/// What an export wrote and how the recording ended.
struct RecordingExportResult {
  std::vector<std::string> files;  ///< paths written, in RecordingExportFileNames() order
  std::int64_t frames = 0;         ///< frames exported (the recording's good frames)
  std::int64_t images = 0;         ///< of them, with a camera image (images/frame_NNNNNN.png)
  int rows = 0;                    ///< the marker grid
  int cols = 0;
  RecordingStatus status = RecordingStatus::kReading;  ///< as RecordingReader::status()
  std::string message;                                 ///< RecordingReader::message()
};

/// The file names an export in `format` writes. For kNpy, with T frames and N = rows * cols
/// markers in grid order: positions_mm, displacements_mm, forces_n, normals (T x N x 3 <f8),
/// valid, contact (T x N |b1), timestamp_s (T <f8), index (T <i8), flags (T <u4),
/// initialize_progress (T <i8), resultant_force_n, resultant_moment_nmm (T x 3 <f8), the slip
/// estimate: slip_state (T <u4, SlipState's value), slip_fraction, friction, friction_sigma,
/// margin, margin_sigma, least_normal_force_n (T <f8), and has_image (T |b1). For kCsv:
/// frames.csv (the frame's fields and its slip estimate) and markers.csv. Both formats write
/// each recorded camera image as images/frame_NNNNNN.png (NNNNNN the exported frame's number).
std::vector<std::string> RecordingExportFileNames(RecordingExportFormat format);

/// Exports a recording's good frames to `folder` (docs/recording.md, "Export").
///
/// The folder is checked before the recording is read: it is created if missing, and a file
/// the export would write that is already there is refused unless options.overwrite. Every
/// file is written under a temporary name and renamed into place only after all of them are
/// complete, so an export that fails leaves no partial file under a final name.
/// A truncated or corrupt recording is exported up to its last good frame and the result
/// says how it ended; it is not an error.
/// @throws Error if the recording cannot be opened or holds no good frame, the folder cannot
///   be created or written, a file exists (without overwrite), or the marker grid changes
///   between frames (kNpy needs one N).
RecordingExportResult ExportRecording(const std::string& recording,
                                      const std::string& folder,
                                      const RecordingExportOptions& options = {});

}  // namespace tac3d
