#include "tac3d/mcap/ros2_messages.h"

#include <fmt/format.h>

#include <cmath>
#include <initializer_list>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/mcap/cdr.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr const char* kTime = "int32 sec\nuint32 nanosec\n";
constexpr const char* kHeader = "builtin_interfaces/Time stamp\nstring frame_id\n";
constexpr const char* kVector3 = "float64 x\nfloat64 y\nfloat64 z\n";

// The main definition, then each dependency as rosbag2's MCAP storage writes it.
RosSchema Schema(std::string name, std::string main,
                 std::initializer_list<std::pair<const char*, const char*>> dependencies) {
  RosSchema schema{std::move(name), std::move(main)};
  for (const auto& [type, text] : dependencies) {
    schema.text += "\n" + std::string(80, '=') + "\nMSG: " + type + "\n" + text;
  }
  return schema;
}

void PutHeader(CdrWriter& cdr, const RosHeader& header) {
  cdr.Put(header.sec);
  cdr.Put(header.nanosec);
  cdr.String(header.frame_id);
}

}  // namespace

std::string RosNameOfSerialNumber(const std::string& sn) {
  std::string name;
  for (const char c : sn) {
    const bool word = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    name += word ? c : '_';
  }
  if (name.empty() || (name[0] >= '0' && name[0] <= '9')) name = "sn_" + name;
  return name;
}

std::string DefaultRosFrameId(const std::string& sn) { return "tac3d_" + RosNameOfSerialNumber(sn); }

RosHeader RosHeaderAt(std::int64_t time_ns, std::string frame_id) {
  constexpr std::int64_t kNsPerS = 1'000'000'000;
  const std::int64_t sec = time_ns >= 0 ? time_ns / kNsPerS : -((-time_ns + kNsPerS - 1) / kNsPerS);
  return {static_cast<std::int32_t>(sec), static_cast<std::uint32_t>(time_ns - sec * kNsPerS),
          std::move(frame_id)};
}

const RosSchema& WrenchStampedSchema() {
  static const RosSchema schema =
      Schema("geometry_msgs/msg/WrenchStamped", "std_msgs/Header header\nWrench wrench\n",
             {{"std_msgs/Header", kHeader},
              {"builtin_interfaces/Time", kTime},
              {"geometry_msgs/Wrench", "Vector3 force\nVector3 torque\n"},
              {"geometry_msgs/Vector3", kVector3}});
  return schema;
}

const RosSchema& PointCloud2Schema() {
  static const RosSchema schema = Schema(
      "sensor_msgs/msg/PointCloud2",
      "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\nbool is_bigendian\n"
      "uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
      {{"std_msgs/Header", kHeader},
       {"builtin_interfaces/Time", kTime},
       {"sensor_msgs/PointField",
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\n"
        "uint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"}});
  return schema;
}

const RosSchema& CompressedImageSchema() {
  static const RosSchema schema =
      Schema("sensor_msgs/msg/CompressedImage", "std_msgs/Header header\nstring format\nuint8[] data\n",
             {{"std_msgs/Header", kHeader}, {"builtin_interfaces/Time", kTime}});
  return schema;
}

const RosSchema& DiagnosticArraySchema() {
  static const RosSchema schema = Schema(
      "diagnostic_msgs/msg/DiagnosticArray", "std_msgs/Header header\nDiagnosticStatus[] status\n",
      {{"std_msgs/Header", kHeader},
       {"builtin_interfaces/Time", kTime},
       {"diagnostic_msgs/DiagnosticStatus",
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\n"
        "string hardware_id\nKeyValue[] values\n"},
       {"diagnostic_msgs/KeyValue", "string key\nstring value\n"}});
  return schema;
}

std::vector<std::uint8_t> CdrWrenchStamped(const RosHeader& header,
                                           const Eigen::Vector3d& force,
                                           const Eigen::Vector3d& torque) {
  CdrWriter cdr;
  PutHeader(cdr, header);
  for (const Eigen::Vector3d* v : {&force, &torque}) {
    for (int i = 0; i < 3; ++i) cdr.Put((*v)[i]);
  }
  return cdr.Take();
}

std::vector<std::uint8_t> CdrFrameWrench(const RosHeader& header, const TactileFrame& frame) {
  return CdrWrenchStamped(header, frame.resultant_force_n, frame.resultant_moment_nmm / 1000.0);
}

std::vector<std::pair<std::string, std::uint32_t>> MarkerCloudFields() {
  return {{"x", 0},  {"y", 4},  {"z", 8},  {"dx", 12}, {"dy", 16},      {"dz", 20},
          {"fx", 24}, {"fy", 28}, {"fz", 32}, {"valid", 36}, {"contact", 37}, {"slip_state", 38}};
}

std::vector<std::uint8_t> CdrMarkerCloud(const RosHeader& header, const TactileFrame& frame) {
  constexpr std::uint8_t kUint8 = 2, kFloat32 = 7;
  constexpr std::uint32_t kFirstByteField = 36;
  CdrWriter cdr;
  PutHeader(cdr, header);
  cdr.Put(static_cast<std::uint32_t>(frame.rows));
  cdr.Put(static_cast<std::uint32_t>(frame.cols));
  const auto fields = MarkerCloudFields();
  cdr.Count(fields.size());
  for (const auto& [name, offset] : fields) {
    cdr.String(name);
    cdr.Put(offset);
    cdr.Put(offset < kFirstByteField ? kFloat32 : kUint8);
    cdr.Put(std::uint32_t{1});
  }
  cdr.Put(false);  // is_bigendian
  cdr.Put(kMarkerPointStep);
  cdr.Put(static_cast<std::uint32_t>(frame.cols * kMarkerPointStep));
  const int n = frame.num_markers();
  std::vector<std::uint8_t> data(static_cast<std::size_t>(n) * kMarkerPointStep, 0);
  bool dense = true;
  for (int i = 0; i < n; ++i) {
    std::uint8_t* point = data.data() + static_cast<std::size_t>(i) * kMarkerPointStep;
    const Eigen::Vector3d* vectors[] = {&frame.positions_mm[i], &frame.displacements_mm[i], &frame.forces_n[i]};
    const double divisors[] = {1000.0, 1000.0, 1.0};  // mm to m (REP 103); N stays
    for (int v = 0; v < 3; ++v) {
      for (int k = 0; k < 3; ++k) {
        const float value = static_cast<float>((*vectors[v])[k] / divisors[v]);
        std::memcpy(point + 4 * (3 * v + k), &value, 4);
      }
    }
    point[36] = frame.valid[i] ? 1 : 0;
    point[37] = frame.contact[i] ? 1 : 0;
    point[38] = static_cast<std::uint8_t>(frame.slip.state);
    dense = dense && frame.valid[i];
  }
  cdr.Bytes(data.data(), data.size());
  cdr.Put(dense);
  return cdr.Take();
}

std::vector<std::uint8_t> CdrCompressedImage(const RosHeader& header,
                                             const std::string& format,
                                             const std::vector<std::uint8_t>& data) {
  CdrWriter cdr;
  PutHeader(cdr, header);
  cdr.String(format);
  cdr.Bytes(data.data(), data.size());
  return cdr.Take();
}

std::vector<std::uint8_t> CdrPngImage(const RosHeader& header, const cv::Mat& image) {
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", image, png)) {
    throw Error(fmt::format("cannot encode a {}x{} image of {} channels as PNG", image.cols, image.rows,
                            image.channels()));
  }
  return CdrCompressedImage(header, "png", png);
}

std::vector<std::uint8_t> CdrDiagnosticArray(const RosHeader& header,
                                             const std::vector<DiagnosticStatus>& status) {
  CdrWriter cdr;
  PutHeader(cdr, header);
  cdr.Count(status.size());
  for (const DiagnosticStatus& s : status) {
    cdr.Put(s.level);
    cdr.String(s.name);
    cdr.String(s.message);
    cdr.String(s.hardware_id);
    cdr.Count(s.values.size());
    for (const auto& [key, value] : s.values) {
      cdr.String(key);
      cdr.String(value);
    }
  }
  return cdr.Take();
}

StatusCadence::StatusCadence(double period_s) : period_s_(period_s) { TAC3D_DEMAND(period_s >= 0); }

std::optional<DiagnosticStatus> StatusCadence::Next(const TactileFrame& frame) {
  ++frames_since_status_;
  if (last_index_ && frame.index > *last_index_ + 1) skipped_since_status_ += frame.index - *last_index_ - 1;
  last_index_ = frame.index;
  if (last_status_s_ && frame.timestamp_s - *last_status_s_ < period_s_) return std::nullopt;
  const std::string rate =
      last_status_s_ ? fmt::format("{:.3f}", static_cast<double>(frames_since_status_) / (frame.timestamp_s - *last_status_s_))
                     : "unknown";
  int valid = 0, contact = 0;
  for (int i = 0; i < frame.num_markers(); ++i) {
    valid += frame.valid[i] ? 1 : 0;
    contact += frame.contact[i] ? 1 : 0;
  }
  const std::string flags = FrameFlagNames(frame.flags);
  DiagnosticStatus status{.level = static_cast<std::uint8_t>(frame.flags == 0 ? 0 : 1),  // OK, or WARN with a flag
                          .name = "tac3d " + frame.sn,
                          .message = flags.empty() ? "ok" : flags,
                          .hardware_id = frame.sn,
                          .values = {{"frame_rate_hz", rate},
                                     {"skipped_frames", std::to_string(skipped_since_status_)},
                                     {"index", std::to_string(frame.index)},
                                     {"markers", std::to_string(frame.num_markers())},
                                     {"lost_markers", std::to_string(frame.num_markers() - valid)},
                                     {"contact_markers", std::to_string(contact)},
                                     {"flags", std::to_string(frame.flags)},
                                     {"flag_names", flags},
                                     {"initialize_progress", std::to_string(frame.initialize_progress)},
                                     {"slip_state", SlipStateName(frame.slip.state)}}};
  last_status_s_ = frame.timestamp_s;
  frames_since_status_ = 0;
  skipped_since_status_ = 0;
  return status;
}

}  // namespace tac3d
