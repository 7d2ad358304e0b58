#include "tac3d/mcap/recording_mcap.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "tac3d/mcap/mcap_writer.h"
#include "tac3d/mcap/ros2_messages.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

struct SensorChannels {
  SensorChannels(std::string id, double status_period_s) : frame_id(std::move(id)), status_cadence(status_period_s) {}
  std::string frame_id;
  std::uint16_t wrench = 0, markers = 0, status = 0;
  std::optional<std::uint16_t> image;  // made at the first image
  StatusCadence status_cadence;
};

}  // namespace

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
        SensorChannels s(options.frame_id.empty() ? DefaultRosFrameId(frame.sn) : options.frame_id,
                         options.status_period_s);
        s.wrench = channel(ns + "/wrench", WrenchStampedSchema());
        s.markers = channel(ns + "/markers", PointCloud2Schema());
        s.status = channel(ns + "/status", DiagnosticArraySchema());
        it = sensors.emplace(frame.sn, std::move(s)).first;
      }
      SensorChannels& s = it->second;
      const auto time_ns = static_cast<std::int64_t>(std::llround(frame.timestamp_s * 1e9));
      const RosHeader header = RosHeaderAt(time_ns, s.frame_id);
      mcap.Write(s.wrench, time_ns, CdrFrameWrench(header, frame));
      mcap.Write(s.markers, time_ns, CdrMarkerCloud(header, frame));
      if (!recorded->image.empty()) {
        if (!s.image) s.image = channel(ns + "/image", CompressedImageSchema());
        try {
          mcap.Write(*s.image, time_ns, CdrPngImage(header, recorded->image));
        } catch (const Error& e) {
          throw Error(fmt::format("frame {} (index {}): {}", result.frames, frame.index, e.what()));
        }
        ++result.images;
      }
      if (const std::optional<DiagnosticStatus> status = s.status_cadence.Next(frame)) {
        mcap.Write(s.status, time_ns, CdrDiagnosticArray(header, {*status}));
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
