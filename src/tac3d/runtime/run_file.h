#pragma once

// The run file of `tac3d run --run-file FILE`: several sensors in one process
// (docs/pipeline.md, "Several sensors").

#include <string>
#include <vector>

#include "tac3d/runtime/sensor_stream.h"

namespace tac3d::runtime {

/// Parses a run file: a mapping with one key, `sensors`, a list of sensors, each with `sn`
/// and `source` (required) and optionally `config`, `gains`, `weight`, `support_resolve`,
/// `recompute_forces`, `reference_frames`,
/// `speed`, `udp`, `udp_items`, `udp_progress`, `record`, `record_images`, `overwrite`, `ros2`,
/// `ros2_reliable`, `ros2_image`, `ros2_frame_id`, `fps`, `exposure`. Relative paths (config, record, a source's file or folder) are taken from
/// `base_dir`.
/// @param source the file name for messages.
/// @throws Error naming the file, the line and the key of a syntax error, a duplicated, unknown
///   or missing key, a value of the wrong type, an empty list or one of more than kMaxSensors
///   sensors, an SN, a record file or a ROS 2 namespace used twice, or `speed` for a source it does not apply to.
std::vector<SensorRunSpec> ParseRunFile(const std::string& text,
                                        const std::string& source,
                                        const std::string& base_dir);

/// Reads and parses a run file (relative paths from its folder). @throws Error as
/// LoadYamlFile and ParseRunFile do.
std::vector<SensorRunSpec> LoadRunFile(const std::string& path);

}  // namespace tac3d::runtime
