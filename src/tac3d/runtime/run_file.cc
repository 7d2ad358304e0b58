#include "tac3d/runtime/run_file.h"

#include <filesystem>
#include <map>

#include <fmt/format.h>

#include "tac3d/runtime/sensor_group.h"
#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::runtime {
namespace {

namespace fs = std::filesystem;

std::string FromBase(const std::string& base_dir, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

// A source's file or folder taken from the run file's folder; a camera is left alone.
std::string ResolveSource(const std::string& base_dir, const std::string& source) {
  for (const char* prefix : {"dataset:", "recording:", "vendor:"}) {
    const std::string p(prefix);
    if (source.rfind(p, 0) == 0) return p + FromBase(base_dir, source.substr(p.size()));
  }
  if (source.rfind("camera:", 0) == 0 || source.rfind("/dev/", 0) == 0) return source;
  return FromBase(base_dir, source);
}

SensorRunSpec ReadSensor(YamlReader r, const std::string& base_dir) {
  SensorRunSpec s;
  s.sn = r.String("sn");
  if (s.sn.empty()) r.FailAt(r.Required("sn"), r.Join("sn"), "must not be empty");
  s.source = ResolveSource(base_dir, r.String("source"));
  s.config = FromBase(base_dir, r.String("config", ""));
  s.gains = r.Vector<3>("gains", s.gains);
  if (r.Has("weight")) s.weight = r.Double("weight");
  if (r.Has("support_resolve")) s.support_resolve = r.Bool("support_resolve");
  s.recompute_forces = r.Bool("recompute_forces", false);
  if (s.recompute_forces && !RecordingSourcePath(s.source) && !VendorSourcePath(s.source)) {
    r.FailAt(r.Required("recompute_forces"), r.Join("recompute_forces"), "applies to recording:FILE and vendor:DIR only");
  }
  s.reference_frames = r.Int("reference_frames", s.reference_frames);
  if (r.Has("drift")) {
    const std::optional<DriftMode> mode = ParseDriftMode(r.String("drift"));
    if (!mode) r.FailAt(r.Required("drift"), r.Join("drift"), "must be off, flag or rezero");
    s.drift.mode = *mode;
  }
  s.drift.time_constant_s = r.Double("drift_time_constant_s", s.drift.time_constant_s);
  if (!(s.drift.time_constant_s > 0)) {
    r.FailAt(r.Required("drift_time_constant_s"), r.Join("drift_time_constant_s"), "must be > 0");
  }
  if (r.Has("speed")) {
    if (!IsPacedSource(s.source)) r.FailAt(r.Required("speed"), r.Join("speed"), "applies to recording:FILE, vendor:DIR or dataset:DIR only");
    s.speed = r.Double("speed");
    if (*s.speed < 0) r.FailAt(r.Required("speed"), r.Join("speed"), "must be >= 0");
  }
  s.camera.fps = r.Double("fps", s.camera.fps);
  s.exposure = r.Double("exposure", s.exposure);
  s.camera.pixel_format = r.String("pixel_format", s.camera.pixel_format);
  try {
    ValidatePixelFormat(s.camera.pixel_format);
  } catch (const Error& e) {
    r.FailAt(r.Required("pixel_format"), r.Join("pixel_format"), e.what());
  }
  s.outputs.udp = r.String("udp", "");
  s.outputs.udp_items = r.String("udp_items", "");
  s.outputs.udp_progress = r.Bool("udp_progress", false);
  s.outputs.allow_zero_under_load = r.Bool("allow_zero_under_load", false);
  s.outputs.record = FromBase(base_dir, r.String("record", ""));
  s.outputs.record_images = r.Bool("record_images", false);
  s.outputs.overwrite = r.Bool("overwrite", false);
  s.outputs.ros2 = r.String("ros2", "");
  s.outputs.ros2_reliable = r.Bool("ros2_reliable", false);
  s.outputs.ros2_image = r.Bool("ros2_image", false);
  s.outputs.ros2_frame_id = r.String("ros2_frame_id", "");
  s.outputs.sn = s.sn;
  // The outputs' own checks (HOST:PORT's form, the record file's folder), named by the line.
  const auto check = [&r](const char* key, const FrameOutputArgs& args) {
    try {
      args.Validate();
    } catch (const Error& e) {
      r.FailAt(r.Required(key), r.Join(key), e.what());
    }
  };
  FrameOutputArgs udp, record;
  udp.udp = s.outputs.udp;
  record.record = s.outputs.record;
  check("udp", udp);
  FrameOutputArgs udp_items = udp, udp_progress = udp;
  udp_items.udp_items = s.outputs.udp_items;
  udp_progress.udp_progress = s.outputs.udp_progress;
  if (r.Has("udp_items")) check("udp_items", udp_items);
  if (r.Has("udp_progress")) check("udp_progress", udp_progress);
  check("record", record);
  FrameOutputArgs ros2;
  ros2.ros2 = s.outputs.ros2;
  ros2.ros2_frame_id = s.outputs.ros2_frame_id;
  if (r.Has("ros2")) check("ros2", ros2);
  for (const char* key : {"ros2_reliable", "ros2_image", "ros2_frame_id"}) {
    if (r.Has(key) && s.outputs.ros2.empty()) r.FailAt(r.Required(key), r.Join(key), "needs ros2: NAMESPACE");
  }
  if (r.Has("ros2_frame_id")) check("ros2_frame_id", ros2);
  return s;
}

}  // namespace

std::vector<SensorRunSpec> ParseRunFile(const std::string& text,
                                        const std::string& source,
                                        const std::string& base_dir) {
  const YAML::Node root = ParseYamlDocument(text, source);
  YamlReader r(root, "", &source);
  const YAML::Node list = r.Sequence("sensors");
  if (list.size() == 0) r.FailAt(list, "sensors", "lists no sensor");
  if (list.size() > static_cast<size_t>(kMaxSensors)) {
    r.FailAt(list[kMaxSensors], fmt::format("sensors[{}]", kMaxSensors),
             fmt::format("a run holds at most {} sensors", kMaxSensors));
  }
  std::vector<SensorRunSpec> sensors;
  std::map<std::string, int> sn_line, record_line, ros2_line;
  for (size_t i = 0; i < list.size(); ++i) {
    sensors.push_back(ReadSensor(r.Element(list, "sensors", i), base_dir));
    const SensorRunSpec& s = sensors.back();
    const int line = list[i].Mark().line + 1;
    const auto refuse_twice = [&](std::map<std::string, int>& seen, const std::string& value, const char* what) {
      const auto [it, inserted] = seen.emplace(value, line);
      if (!inserted) {
        throw Error(fmt::format("{}: line {}: sensors[{}]: {} '{}' is used twice (first at line {})", source,
                                line, i, what, value, it->second));
      }
    };
    refuse_twice(sn_line, s.sn, "sn");
    if (!s.outputs.record.empty()) refuse_twice(record_line, s.outputs.record, "record file");
    if (!s.outputs.ros2.empty()) refuse_twice(ros2_line, Ros2Namespace(s.outputs.ros2), "ROS 2 namespace");
  }
  return sensors;
}

std::vector<SensorRunSpec> LoadRunFile(const std::string& path) {
  return ParseRunFile(ReadFileCapped(path, kMaxConfigFileBytes, "run file"), path,
                      fs::path(path).parent_path().string());
}

}  // namespace tac3d::runtime
