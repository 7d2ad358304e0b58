#pragma once

// A sensor's frames as ROS 2 topics (docs/ros2.md), published with Cyclone DDS the way ROS 2's
// own DDS layer does it, so an unmodified ROS 2 node (Humble, Jazzy) reads them without any
// tac3d package: topic `rt` + the ROS name, type `<package>::msg::dds_::<Type>_`, classic CDR.

#include <cstdint>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

/// The full form ("/tac3d/left") of a ROS 2 namespace given with or without its leading '/'.
/// @throws Error unless it is one or more tokens of [A-Za-z0-9_] joined by '/', none starting
///   with a digit, at most kMaxRos2NamespaceLength characters.
std::string Ros2Namespace(const std::string& ns);
inline constexpr std::size_t kMaxRos2NamespaceLength = 200;

/// How one sensor publishes (tac3d run --ros2 ...; a run file's `ros2` keys).
struct Ros2PublisherOptions {
  /// NAMESPACE: the topics NAMESPACE/wrench, /markers, /status (and /image), the subscription
  /// NAMESPACE/zero. Ros2Namespace's rules.
  std::string ns;
  /// ROS 2's default profile (reliable, volatile, keep-last 10) instead of its sensor-data
  /// profile (best effort, volatile, keep-last 5). A reliable writer may wait (up to 100 ms) for a
  /// reader that lags behind.
  bool reliable = false;
  /// Also publish NAMESPACE/image, the camera frame as PNG (costs milliseconds a frame).
  bool image = false;
  /// Every header's frame_id; "" DefaultRosFrameId(the frame's SN).
  std::string frame_id{};
  /// How often NAMESPACE/status goes out (s of frame time; StatusCadence).
  double status_period_s = 1.0;

  /// @throws Error naming the field: the namespace (Ros2Namespace), a frame_id of other
  ///   characters than [A-Za-z0-9_/] or starting with '/' (tf2 refuses it), a period < 0 or not
  ///   finite.
  void Validate() const;
};

/// What a publisher did.
struct Ros2PublisherStats {
  std::int64_t frames = 0;          ///< frames published
  /// Samples not written: a writer refused them, or more than 64 waited (a reliable reader lagging).
  std::int64_t failed_writes = 0;
  std::int64_t zero_requests = 0;   ///< messages received on NAMESPACE/zero
};

/// One sensor's topics. Every publisher of a process shares one DDS participant, made by the
/// first on the domain ROS_DOMAIN_ID (0 when unset), configured by CYCLONEDDS_URI (Cyclone's
/// own variable, left as it is). Not thread-safe: one thread per publisher (publishers on
/// different threads are fine).
class Ros2Publisher {
 public:
  /// @throws Error if the options are invalid, ROS_DOMAIN_ID is not 0-232, or DDS cannot start
  ///   (a bad CYCLONEDDS_URI, no usable network interface) or make the topics.
  explicit Ros2Publisher(const Ros2PublisherOptions& options);
  ~Ros2Publisher();
  Ros2Publisher(const Ros2Publisher&) = delete;
  Ros2Publisher& operator=(const Ros2Publisher&) = delete;

  /// Publishes the frame: wrench and markers, the image when asked for and `image` is not empty,
  /// the status when due. The messages are encoded on the caller's thread and written by the
  /// publisher's own, in order (what the caller pays: bench/ros2_benchmark.cc). Stamps are the frames' capture times on the system clock: the clock
  /// at the first frame less its timestamp_s, plus each frame's timestamp_s.
  /// @throws Error if the image cannot be encoded. A sample a writer does not take is counted
  ///   (stats().failed_writes), not thrown: the sensor goes on.
  void Publish(const TactileFrame& frame, const cv::Mat& image);

  /// Whether a message arrived on NAMESPACE/zero since the last call (several count as one).
  bool TakeZeroRequest();

  Ros2PublisherStats stats() const;
  /// The readers NAMESPACE/markers is matched with now (DDS discovery found them).
  int subscribers() const;
  /// The namespace in its full form ("/tac3d/left").
  const std::string& topic_namespace() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tac3d
