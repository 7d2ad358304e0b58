#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

// The standard ROS 2 messages (Humble, Jazzy) a tac3d MCAP export holds (docs/recording.md,
// "Export to MCAP"), CDR-encoded, and their `ros2msg` schemas as rosbag2 writes them.

/// std_msgs/Header: stamp (sec, nanosec) and frame_id.
struct RosHeader {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  std::string frame_id;
};

/// A time in ns split into the Header's sec and nanosec.
RosHeader RosHeaderAt(std::int64_t time_ns, std::string frame_id);

/// A ROS 2 type's name ("geometry_msgs/msg/WrenchStamped") and its ros2msg schema: the type's
/// definition, then each type it depends on after a line of 80 '=' and `MSG: package/Type`.
struct RosSchema {
  std::string name;
  std::string text;
};
const RosSchema& WrenchStampedSchema();
const RosSchema& PointCloud2Schema();
const RosSchema& CompressedImageSchema();
const RosSchema& DiagnosticArraySchema();

/// geometry_msgs/msg/WrenchStamped.
std::vector<std::uint8_t> CdrWrenchStamped(const RosHeader& header,
                                           const Eigen::Vector3d& force,
                                           const Eigen::Vector3d& torque);

/// The PointCloud2 fields of a marker cloud, in order: float32 x y z (m), dx dy dz (m),
/// fx fy fz (N) at offsets 0..32, then uint8 valid, contact (0, 1) and slip_state (the
/// frame's SlipState value) at 36, 37, 38; point_step 40.
inline constexpr std::uint32_t kMarkerPointStep = 40;
std::vector<std::pair<std::string, std::uint32_t>> MarkerCloudFields();

/// sensor_msgs/msg/PointCloud2 of the frame's markers: height rows, width cols (grid order),
/// lost markers NaN and is_dense false when any is lost; SI units.
std::vector<std::uint8_t> CdrMarkerCloud(const RosHeader& header, const TactileFrame& frame);

/// sensor_msgs/msg/CompressedImage.
std::vector<std::uint8_t> CdrCompressedImage(const RosHeader& header,
                                             const std::string& format,
                                             const std::vector<std::uint8_t>& data);

/// diagnostic_msgs/msg/DiagnosticStatus.
struct DiagnosticStatus {
  std::uint8_t level = 0;  ///< OK 0, WARN 1, ERROR 2, STALE 3
  std::string name;
  std::string message;
  std::string hardware_id;
  std::vector<std::pair<std::string, std::string>> values;
};

/// diagnostic_msgs/msg/DiagnosticArray.
std::vector<std::uint8_t> CdrDiagnosticArray(const RosHeader& header,
                                             const std::vector<DiagnosticStatus>& status);

}  // namespace tac3d
