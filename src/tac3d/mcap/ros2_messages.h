#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

// The standard ROS 2 messages (Humble, Jazzy) of a sensor's frames, CDR-encoded, and their
// `ros2msg` schemas as rosbag2 writes them: what a tac3d MCAP export holds (docs/recording.md,
// "Export to MCAP") and what `tac3d run --ros2` publishes (docs/ros2.md), from the same code.

/// The SN as one ROS 2 name token: every character but [A-Za-z0-9_] an '_', and "sn_" before a
/// leading digit ("AD2-0065L" -> "AD2_0065L"), so topic names made of it are valid.
std::string RosNameOfSerialNumber(const std::string& sn);

/// A sensor's frame_id unless one is given: "tac3d_" + RosNameOfSerialNumber(sn).
std::string DefaultRosFrameId(const std::string& sn);

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

/// geometry_msgs/msg/WrenchStamped of the frame's resultants in SI units (REP 103): the force in
/// N, the moment about the sensor origin in N m (the pipeline's N mm / 1000).
std::vector<std::uint8_t> CdrFrameWrench(const RosHeader& header, const TactileFrame& frame);

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

/// sensor_msgs/msg/CompressedImage of a camera image as PNG (lossless).
/// @throws Error if OpenCV cannot encode it.
std::vector<std::uint8_t> CdrPngImage(const RosHeader& header, const cv::Mat& image);

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

/// When a sensor's status (diagnostic_msgs/msg/DiagnosticArray) goes out, and what it says: its
/// first frame, then the first frame at least `period_s` of frame time after the last status.
/// One per sensor; frames in the order they were emitted.
class StatusCadence {
 public:
  /// @pre period_s >= 0 (0: every frame).
  explicit StatusCadence(double period_s);

  /// Counts `frame`; when a status is due, returns it: level OK, or WARN with a flag set (its
  /// names the message), values frame_rate_hz (frames since the last status over its time;
  /// "unknown" in the first), skipped_frames (gaps in the frame index since the last status:
  /// frames the source or the pipeline dropped), index, markers, lost_markers, contact_markers,
  /// flags, flag_names (drift_at_rest, lighting_changed, ...), initialize_progress, slip_state.
  std::optional<DiagnosticStatus> Next(const TactileFrame& frame);

 private:
  double period_s_;
  std::optional<double> last_status_s_;
  std::optional<std::int64_t> last_index_;
  std::int64_t frames_since_status_ = 0;  // after the last status, up to this one
  std::int64_t skipped_since_status_ = 0;
};

}  // namespace tac3d
