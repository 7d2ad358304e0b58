#include "tac3d/mcap/recording_mcap.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/mcap/mcap_writer.h"
#include "tac3d/mcap/ros2_messages.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

struct SensorChannels {
  std::string frame_id;
  std::uint16_t wrench = 0, markers = 0, status = 0;
  std::optional<std::uint16_t> image;  // made at the first image
  std::optional<double> last_status_s;
  std::int64_t frames_since_status = 0;  // after the last status, up to this one
};

DiagnosticStatus StatusOf(const TactileFrame& frame, const std::string& rate_hz) {
  int valid = 0, contact = 0;
  for (int i = 0; i < frame.num_markers(); ++i) {
    valid += frame.valid[i] ? 1 : 0;
    contact += frame.contact[i] ? 1 : 0;
  }
  const std::string flags = FrameFlagNames(frame.flags);
  return {.level = static_cast<std::uint8_t>(frame.flags == 0 ? 0 : 1),  // OK, or WARN with a flag
          .name = "tac3d " + frame.sn,
          .message = flags.empty() ? "ok" : flags,
          .hardware_id = frame.sn,
          .values = {{"frame_rate_hz", rate_hz},
                     {"index", std::to_string(frame.index)},
                     {"markers", std::to_string(frame.num_markers())},
                     {"lost_markers", std::to_string(frame.num_markers() - valid)},
                     {"contact_markers", std::to_string(contact)},
                     {"flags", std::to_string(frame.flags)},
                     {"flag_names", flags},
                     {"initialize_progress", std::to_string(frame.initialize_progress)},
                     {"slip_state", SlipStateName(frame.slip.state)}}};
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

std::string McapTopicNamespace(const std::string& sn) { return "/tac3d/" + RosNameOfSerialNumber(sn); }

McapExportResult ExportFramesToMcap(const std::string& path,
                                    const std::function<std::optional<RecordedFrame>()>& next,
                                    const McapExportOptions& options,
                                    const std::vector<std::string>& inputs) {
  CheckOutputFile(path, "MCAP file", {".mcap"}, inputs);
  if (!options.overwrite && std::filesystem::exists(path)) {
    throw Error(fmt::format(
        "'{}' already exists (`tac3d recording export --overwrite`, McapExportOptions::overwrite, replaces it)",
        path));
  }
  McapExportResult result;
  WriteFileAtomically(path, [&](const std::string& temporary) {
    McapWriter mcap(temporary, "ros2", options.chunk_bytes);
    std::map<const RosSchema*, std::uint16_t> schema_ids;
    const auto channel = [&](const std::string& topic, const RosSchema& schema) {
      auto it = schema_ids.find(&schema);
      if (it == schema_ids.end()) it = schema_ids.emplace(&schema, mcap.AddSchema(schema.name, "ros2msg", schema.text)).first;
      result.topics.push_back(topic);
      return mcap.AddChannel(it->second, topic, "cdr");
    };
    std::map<std::string, SensorChannels> sensors;
    while (std::optional<RecordedFrame> recorded = next()) {
      const TactileFrame& frame = recorded->frame;
      if (!(frame.timestamp_s >= 0.0)) {
        throw Error(fmt::format("frame {} (index {}) has timestamp {} s: MCAP's times are unsigned", result.frames,
                                frame.index, frame.timestamp_s));
      }
      const std::string ns = McapTopicNamespace(frame.sn);
      auto it = sensors.find(frame.sn);
      if (it == sensors.end()) {
        SensorChannels s;
        s.frame_id = options.frame_id.empty() ? "tac3d_" + RosNameOfSerialNumber(frame.sn) : options.frame_id;
        s.wrench = channel(ns + "/wrench", WrenchStampedSchema());
        s.markers = channel(ns + "/markers", PointCloud2Schema());
        s.status = channel(ns + "/status", DiagnosticArraySchema());
        it = sensors.emplace(frame.sn, std::move(s)).first;
      }
      SensorChannels& s = it->second;
      const auto time_ns = static_cast<std::int64_t>(std::llround(frame.timestamp_s * 1e9));
      const RosHeader header = RosHeaderAt(time_ns, s.frame_id);
      mcap.Write(s.wrench, time_ns,
                 CdrWrenchStamped(header, frame.resultant_force_n, frame.resultant_moment_nmm / 1000.0));  // N mm -> N m
      mcap.Write(s.markers, time_ns, CdrMarkerCloud(header, frame));
      if (!recorded->image.empty()) {
        if (!s.image) s.image = channel(ns + "/image", CompressedImageSchema());
        std::vector<std::uint8_t> png;
        if (!cv::imencode(".png", recorded->image, png)) {
          throw Error(fmt::format("frame {} (index {}): cannot encode its image as PNG", result.frames, frame.index));
        }
        mcap.Write(*s.image, time_ns, CdrCompressedImage(header, "png", png));
        ++result.images;
      }
      // The sensor's first frame's status, then the first frame a period after the last status.
      ++s.frames_since_status;
      if (!s.last_status_s || frame.timestamp_s - *s.last_status_s >= options.status_period_s) {
        const std::string rate =
            s.last_status_s
                ? fmt::format("{:.3f}", static_cast<double>(s.frames_since_status) / (frame.timestamp_s - *s.last_status_s))
                : "unknown";
        mcap.Write(s.status, time_ns, CdrDiagnosticArray(header, {StatusOf(frame, rate)}));
        s.last_status_s = frame.timestamp_s;
        s.frames_since_status = 0;
      }
      ++result.frames;
    }
    if (result.frames == 0) throw Error(fmt::format("no frame to export to '{}'", path));
    mcap.Close();
    result.messages = mcap.messages();
  });
  return result;
}

}  // namespace tac3d
