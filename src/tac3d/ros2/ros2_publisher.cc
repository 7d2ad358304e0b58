#include "tac3d/ros2/ros2_publisher.h"

#include <dds/dds.h>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>

#include "std_msgs_empty.h"  // idlc's, in the build folder
#include "tac3d/mcap/ros2_messages.h"
#include "tac3d/ros2/cdr_topic.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

bool IsWordChar(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_'; }

// ROS_DOMAIN_ID as ROS 2 reads it: unset or empty 0; 0-232 (a domain's ports stay below 65536).
std::uint32_t RosDomainId() {
  const char* env = std::getenv("ROS_DOMAIN_ID");
  if (env == nullptr || *env == '\0') return 0;
  char* end = nullptr;
  const long id = std::strtol(env, &end, 10);
  if (*end != '\0' || id < 0 || id > 232) {
    throw Error(fmt::format("ROS_DOMAIN_ID '{}' must be a domain id 0-232 (ROS 2 uses 0-101 safely)", env));
  }
  return static_cast<std::uint32_t>(id);
}

// A QoS object, deleted with it.
struct Qos {
  Qos() : qos(dds_create_qos()) {}
  ~Qos() { dds_delete_qos(qos); }
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  dds_qos_t* qos;
};

// ROS 2's profiles: default (reliable, keep-last 10) or sensor data (best effort, keep-last 5),
// both volatile; classic CDR (XCDR1), the only encoding ROS 2 Humble's readers take.
void SetRosQos(dds_qos_t* qos, bool reliable) {
  dds_qset_reliability(qos, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, reliable ? 10 : 5);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
}

std::int64_t RealtimeNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

namespace internal {

// The process's one DDS participant, shared by its publishers; deleted with the last. Not in
// the anonymous namespace: Ros2Publisher::Impl holds one.
class Participant {
 public:
  static std::shared_ptr<Participant> Shared() {
    static std::mutex mutex;
    static std::weak_ptr<Participant> shared;
    std::lock_guard lock(mutex);
    std::shared_ptr<Participant> participant = shared.lock();
    if (!participant) {
      participant.reset(new Participant(RosDomainId()));
      shared = participant;
    }
    return participant;
  }
  ~Participant() { dds_delete(entity_); }
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  dds_entity_t entity() const { return entity_; }

 private:
  explicit Participant(std::uint32_t domain) : entity_(dds_create_participant(domain, nullptr, nullptr)) {
    if (entity_ < 0) {
      const char* uri = std::getenv("CYCLONEDDS_URI");
      throw Error(fmt::format("cannot start DDS (Cyclone DDS) on ROS 2 domain {}: {}; {}", domain,
                              dds_strretcode(entity_),
                              uri != nullptr && *uri != '\0'
                                  ? fmt::format("check CYCLONEDDS_URI '{}' (Cyclone's messages above say what it refused)", uri)
                                  : "is a network interface up? (CYCLONEDDS_URI can name one: docs/ros2.md)"));
    }
  }
  dds_entity_t entity_;
};

}  // namespace internal

std::string Ros2Namespace(const std::string& ns) {
  const std::string full = ns.starts_with('/') ? ns : "/" + ns;
  const auto refuse = [&](const std::string& why) {
    throw Error(fmt::format("ROS 2 namespace '{}' {}: expected names of letters, digits and '_' joined by '/', "
                            "e.g. tac3d/left",
                            ns, why));
  };
  if (full.size() > kMaxRos2NamespaceLength) refuse(fmt::format("is longer than {} characters", kMaxRos2NamespaceLength));
  std::size_t token = 1;  // where the current name starts
  for (std::size_t i = 1; i <= full.size(); ++i) {
    if (i < full.size() && full[i] != '/') {
      if (!IsWordChar(full[i])) refuse(fmt::format("has a '{}'", full[i]));
      continue;
    }
    if (i == token) refuse(full.size() == 1 ? "is empty" : "has an empty name (a '/' at its end or twice)");
    if (full[token] >= '0' && full[token] <= '9') refuse("has a name starting with a digit");
    token = i + 1;
  }
  return full;
}

void Ros2PublisherOptions::Validate() const {
  Ros2Namespace(ns);
  for (const char c : frame_id) {
    if (!IsWordChar(c) && c != '/') {
      throw Error(fmt::format("ROS 2 frame_id '{}' has a '{}': expected letters, digits, '_' and '/'", frame_id, c));
    }
  }
  if (frame_id.starts_with('/')) {
    throw Error(fmt::format("ROS 2 frame_id '{}' starts with '/': tf2 refuses such frames", frame_id));
  }
  if (!(status_period_s >= 0) || !std::isfinite(status_period_s)) {
    throw Error(fmt::format("ROS 2 status period {} s must be >= 0", status_period_s));
  }
}

// The samples a publisher's thread writes, in order, so that the sensor's thread pays for the
// encoding only: a write through the network stack costs it tens of microseconds, and a reliable
// writer may wait for a lagging reader.
class WriteQueue {
 public:
  // More samples than this waiting (a writer stuck on a reader): the oldest are dropped.
  static constexpr std::size_t kMaxQueued = 64;

  WriteQueue() : thread_([this] { Loop(); }) {}
  ~WriteQueue() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_one();
    thread_.join();
  }

  void Push(dds_entity_t writer, const internal::CdrTopic& topic, std::vector<std::uint8_t> cdr) {
    {
      std::lock_guard lock(mutex_);
      if (queue_.size() >= kMaxQueued) {
        queue_.pop_front();
        ++failed_;
      }
      queue_.push_back({writer, &topic, std::move(cdr)});
    }
    wake_.notify_one();
  }

  std::int64_t failed() const { return failed_; }

 private:
  struct Sample {
    dds_entity_t writer;
    const internal::CdrTopic* topic;
    std::vector<std::uint8_t> cdr;
  };

  // Writes until stopped, the queue drained.
  void Loop() {
    std::unique_lock lock(mutex_);
    while (true) {
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;
      Sample sample = std::move(queue_.front());
      queue_.pop_front();
      lock.unlock();
      if (internal::WriteCdr(sample.writer, *sample.topic, std::move(sample.cdr)) < 0) ++failed_;
      lock.lock();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Sample> queue_;
  bool stopping_ = false;
  std::atomic<std::int64_t> failed_{0};
  std::thread thread_;  // last: started once the rest is made
};

struct Ros2Publisher::Impl {
  Ros2PublisherOptions options;
  std::string ns;
  std::shared_ptr<internal::Participant> participant;
  // Deleted (with their writers and reader) before the participant goes.
  std::vector<dds_entity_t> entities;
  internal::CdrTopic wrench_topic, markers_topic, status_topic, image_topic;
  dds_entity_t wrench = 0, markers = 0, status = 0, image = 0, zero = 0;
  StatusCadence status_cadence;
  std::optional<std::int64_t> stamp_offset_ns;  // the system clock less the frames' time
  std::string frame_id_sn;                      // the SN frame_id was made for
  std::string frame_id;
  Ros2PublisherStats stats;
  std::optional<WriteQueue> writes;  // made last, stopped first

  explicit Impl(const Ros2PublisherOptions& o)
      : options(o), ns(Ros2Namespace(o.ns)), participant(internal::Participant::Shared()), status_cadence(o.status_period_s) {}

  ~Impl() {
    writes.reset();  // every sample queued is written
    for (auto it = entities.rbegin(); it != entities.rend(); ++it) dds_delete(*it);
  }

  dds_entity_t Check(dds_entity_t entity, const std::string& what) {
    if (entity < 0) {
      throw Error(fmt::format("cannot create the DDS {} for ROS 2 topic {}: {}", what, ns, dds_strretcode(entity)));
    }
    entities.push_back(entity);
    return entity;
  }

  // The writer of NAMESPACE/name, of the DDS type `type`.
  dds_entity_t Writer(internal::CdrTopic& topic, const std::string& name, const std::string& type) {
    topic = internal::CreateCdrTopic(participant->entity(), "rt" + ns + "/" + name, type);
    Check(topic.topic, "topic " + name);
    Qos qos;
    SetRosQos(qos.qos, options.reliable);
    return Check(dds_create_writer(participant->entity(), topic.topic, qos.qos, nullptr), "writer of " + name);
  }

  // NAMESPACE/zero, as `ros2 topic pub` sends it: ROS 2's default profile.
  dds_entity_t ZeroReader() {
    const dds_entity_t topic = Check(dds_create_topic(participant->entity(), &std_msgs_msg_dds__Empty__desc,
                                                      ("rt" + ns + "/zero").c_str(), nullptr, nullptr),
                                     "topic zero");
    Qos qos;
    SetRosQos(qos.qos, /*reliable=*/true);
    return Check(dds_create_reader(participant->entity(), topic, qos.qos, nullptr), "reader of zero");
  }

  void Write(dds_entity_t writer, const internal::CdrTopic& topic, std::vector<std::uint8_t> cdr) {
    writes->Push(writer, topic, std::move(cdr));
  }
};

Ros2Publisher::Ros2Publisher(const Ros2PublisherOptions& options) {
  options.Validate();
  impl_ = std::make_unique<Impl>(options);
  Impl& p = *impl_;
  p.wrench = p.Writer(p.wrench_topic, "wrench", "geometry_msgs::msg::dds_::WrenchStamped_");
  p.markers = p.Writer(p.markers_topic, "markers", "sensor_msgs::msg::dds_::PointCloud2_");
  p.status = p.Writer(p.status_topic, "status", "diagnostic_msgs::msg::dds_::DiagnosticArray_");
  if (options.image) p.image = p.Writer(p.image_topic, "image", "sensor_msgs::msg::dds_::CompressedImage_");
  p.zero = p.ZeroReader();
  p.writes.emplace();
}

Ros2Publisher::~Ros2Publisher() = default;

void Ros2Publisher::Publish(const TactileFrame& frame, const cv::Mat& image) {
  Impl& p = *impl_;
  const auto frame_ns = static_cast<std::int64_t>(std::llround(frame.timestamp_s * 1e9));
  if (!p.stamp_offset_ns) p.stamp_offset_ns = RealtimeNs() - frame_ns;
  if (p.frame_id.empty() || p.frame_id_sn != frame.sn) {
    p.frame_id_sn = frame.sn;
    p.frame_id = p.options.frame_id.empty() ? DefaultRosFrameId(frame.sn) : p.options.frame_id;
  }
  const RosHeader header = RosHeaderAt(*p.stamp_offset_ns + frame_ns, p.frame_id);
  p.Write(p.wrench, p.wrench_topic, CdrFrameWrench(header, frame));
  p.Write(p.markers, p.markers_topic, CdrMarkerCloud(header, frame));
  if (p.image != 0 && !image.empty()) p.Write(p.image, p.image_topic, CdrPngImage(header, image));
  if (const std::optional<DiagnosticStatus> status = p.status_cadence.Next(frame)) {
    p.Write(p.status, p.status_topic, CdrDiagnosticArray(header, {*status}));
  }
  ++p.stats.frames;
}

bool Ros2Publisher::TakeZeroRequest() {
  Impl& p = *impl_;
  bool requested = false;
  std_msgs_msg_dds__Empty_ sample{};
  void* samples[1] = {&sample};
  dds_sample_info_t info;
  while (dds_take(p.zero, samples, &info, 1, 1) > 0) {
    if (!info.valid_data) continue;
    requested = true;
    ++p.stats.zero_requests;
  }
  return requested;
}

Ros2PublisherStats Ros2Publisher::stats() const {
  Ros2PublisherStats stats = impl_->stats;
  stats.failed_writes = impl_->writes->failed();
  return stats;
}

int Ros2Publisher::subscribers() const {
  dds_publication_matched_status_t status;
  if (dds_get_publication_matched_status(impl_->markers, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}

const std::string& Ros2Publisher::topic_namespace() const { return impl_->ns; }

}  // namespace tac3d
