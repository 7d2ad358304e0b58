#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/record/recording.h"

namespace tac3d {

/// What a recording holds, read through to its end: `tac3d recording info`. Fields start at
/// "nothing read" values; duration and rates are over the good frames only.
struct RecordingInfo {
  struct Grid {
    int rows = 0;
    int cols = 0;
    bool operator==(const Grid&) const = default;
  };

  std::string path;
  std::int64_t file_bytes = 0;
  /// Bytes up to the end of the last good record (the rest is the truncated or corrupt tail).
  std::int64_t good_bytes = 0;
  std::int64_t frames = 0;  ///< good frames
  std::int64_t frames_with_image = 0;
  std::int64_t first_index = 0;
  std::int64_t last_index = 0;
  double first_timestamp_s = 0.0;
  double last_timestamp_s = 0.0;
  /// Frames whose index is not the previous one's + 1 (frames dropped while recording).
  std::int64_t index_gaps = 0;
  /// Frames whose timestamp is before the previous one's.
  std::int64_t timestamps_backwards = 0;
  std::vector<std::string> sns;   ///< distinct, in order of first appearance
  std::vector<Grid> grids;        ///< distinct marker grids, in order of first appearance
  std::vector<Grid> image_sizes;  ///< distinct image sizes (rows x cols), in that order
  /// Frames carrying each FrameFlag, in kAllFrameFlags order.
  std::array<std::int64_t, std::size(kAllFrameFlags)> flag_frames{};
  std::int64_t unflagged_frames = 0;  ///< frames with no flag at all
  RecordingStatus status = RecordingStatus::kReading;
  std::string message;  ///< RecordingReader::message(): why and where the file ended

  double duration_s() const { return frames > 0 ? last_timestamp_s - first_timestamp_s : 0.0; }
  /// Frames per second over the recording, (frames - 1) / duration; 0 if undefined.
  double mean_fps() const;
  std::int64_t tail_bytes() const { return file_bytes - good_bytes; }
  /// One line: "run.tac3d: 600 frames, 6.66 s, SN AD2-0065L, 20 x 20, complete".
  std::string BriefReport() const;
  /// A table of every field.
  std::string FullReport() const;
};

/// Reads the recording through (images included, one frame at a time) and summarises it. A
/// truncated or corrupt file is not an error: the summary covers its good frames and status
/// says how it ended.
/// @throws Error if the file cannot be opened or is not a recording.
RecordingInfo ReadRecordingInfo(const std::string& path);

}  // namespace tac3d
