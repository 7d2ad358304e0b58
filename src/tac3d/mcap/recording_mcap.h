#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/mcap/ros2_messages.h"
#include "tac3d/record/recording.h"

namespace tac3d {

// A recording's frames as a ROS 2 bag in MCAP (docs/recording.md, "Export to MCAP"): per sensor,
// under /tac3d/<SN>, `wrench` (geometry_msgs/msg/WrenchStamped), `markers`
// (sensor_msgs/msg/PointCloud2), `image` (sensor_msgs/msg/CompressedImage, PNG, frames with an
// image) and `status` (diagnostic_msgs/msg/DiagnosticArray, the first frame and then about
// once a second), CDR-encoded, stamped with the frame's timestamp.

/// The topics' prefix, "/tac3d/" + RosNameOfSerialNumber(sn).
std::string McapTopicNamespace(const std::string& sn);

struct McapExportOptions {
  /// Every message's header.frame_id; empty: DefaultRosFrameId(sn).
  std::string frame_id;
  /// false: refuse to replace an existing file.
  bool overwrite = false;
  /// How often a sensor's status goes out (s of frame time).
  double status_period_s = 1.0;
  /// A chunk is written once its messages exceed this many bytes.
  std::size_t chunk_bytes = 1u << 20;
};

struct McapExportResult {
  std::int64_t frames = 0;
  std::int64_t images = 0;
  std::uint64_t messages = 0;
  std::vector<std::string> topics;  ///< in the order their channels were made
};

/// Writes the frames `next` gives (nullopt at the end) to the MCAP file `path`, one frame at a
/// time, through a temporary file renamed into place when complete.
/// @param inputs the files the frames come from: `path` may not be one of them (CheckOutputFile).
/// @throws Error if `path` is refused by CheckOutputFile (or does not end in .mcap), exists
///   without options.overwrite, there is no frame, a timestamp is negative (MCAP's times are
///   unsigned), or a write fails.
McapExportResult ExportFramesToMcap(const std::string& path,
                                    const std::function<std::optional<RecordedFrame>()>& next,
                                    const McapExportOptions& options = {},
                                    const std::vector<std::string>& inputs = {});

}  // namespace tac3d
