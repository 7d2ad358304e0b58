#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/runtime/run_file.h"
#include "tac3d/runtime/run_outputs.h"
#include "tac3d/runtime/sensor_group.h"
#include "tac3d/runtime/sensor_stream.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

using runtime::FrameOutputArgs;
using runtime::SensorRunSpec;

struct RunArgs {
  SensorRunSpec sensor;  // the one-sensor flags
  std::string run_file;
  std::string cache_dir = DefaultCacheDir();
  std::vector<double> gains = {1.0, 1.0, 1.0};
  double weight = 0.0;          // with --weight
  std::string support_resolve;  // on or off, with --support-resolve
  long max_frames = 0;
  double speed = 1.0;
  bool json = false;
  FrameOutputArgs viewer;  // web, web_root, web_hold_s
};

// The one-sensor flags' outputs: the sensor's and the viewer's.
FrameOutputArgs OutputArgs(const RunArgs& a) {
  FrameOutputArgs args = a.sensor.outputs;
  args.sn = a.sensor.sn;
  args.json = a.json;
  args.web = a.viewer.web;
  args.web_root = a.viewer.web_root;
  args.web_hold_s = a.viewer.web_hold_s;
  return args;
}

// The inverse's flags given (--weight, --support-resolve, --gains) into the sensor's spec.
void SetForceOptions(RunArgs& a, const CLI::App& cmd) {
  if (a.gains.size() != 3) throw Error("--gains takes three numbers: Cx Cy Cz");
  a.sensor.gains = Eigen::Vector3d(a.gains[0], a.gains[1], a.gains[2]);
  if (cmd.count("--weight") > 0) a.sensor.weight = a.weight;
  if (cmd.count("--support-resolve") > 0) a.sensor.support_resolve = a.support_resolve == "on";
}

// `sn_given`: --sn was on the command line; without it an imported sensor streams under its own SN.
void Run(RunArgs a, bool sn_given) {
  if (!sn_given) a.sensor.sn = DefaultSerialNumber(LoadSensorOrDefault(a.sensor.config));
  // Checked before the compliance model is loaded (or built, ~1 min).
  OutputArgs(a).Validate();
  const std::unique_ptr<runtime::SensorStream> stream =
      runtime::OpenSensorStream(a.sensor, runtime::CachedModelLoader(a.cache_dir));
  runtime::RunSingleSensor(*stream, OutputArgs(a), a.max_frames, "processed");
}

// `tac3d run --source recording:FILE` or `vendor:DIR`: the frames as they were computed (or
// with --recompute-forces, their forces anew), with --sn's SN if given.
void RunReplay(const RunArgs& a, bool replace_sn) {
  SensorRunSpec spec = a.sensor;
  spec.speed = a.speed;
  const std::optional<std::string> recording = runtime::RecordingSourcePath(spec.source);
  const runtime::ModelLoader load_model = runtime::CachedModelLoader(a.cache_dir);
  const std::unique_ptr<runtime::SensorStream> stream =
      recording ? runtime::OpenRecordingStream(*recording, spec, replace_sn, load_model)
                : runtime::OpenVendorStream(*runtime::VendorSourcePath(spec.source), spec, replace_sn, load_model);
  FrameOutputArgs outputs = OutputArgs(a);
  if (!replace_sn) outputs.sn = {};
  runtime::RunSingleSensor(*stream, outputs, a.max_frames,
                           "replayed from " + (recording ? *recording : *runtime::VendorSourcePath(spec.source)));
}

// `tac3d run --run-file FILE`: every sensor's report, then an error if any failed.
void RunFile(const RunArgs& a) {
  const std::vector<SensorRunSpec> sensors = runtime::LoadRunFile(a.run_file);
  a.viewer.Validate();
  const std::shared_ptr<WebServer> viewer = a.viewer.web.empty() ? nullptr : runtime::OpenViewer(a.viewer);
  std::vector<runtime::SensorReport> reports;
  {
    runtime::StopSignals signals;
    runtime::StopSignals::flag() = false;
    reports = runtime::RunSensorGroup(sensors, runtime::CachedModelLoader(a.cache_dir),
                                      {.max_frames = a.max_frames, .json = a.json}, viewer,
                                      runtime::StopSignals::flag());
  }
  runtime::HoldViewer(viewer.get(), a.viewer.web_hold_s);
  std::vector<std::string> failed;
  for (const runtime::SensorReport& r : reports) {
    if (!r.failure.empty()) failed.push_back(r.sn);
  }
  std::fprintf(stderr, "%zu sensors, %zu failed\n", reports.size(), failed.size());
  if (!failed.empty()) throw Error(fmt::format("sensor(s) failed: {} (see above)", fmt::join(failed, ", ")));
}

// The one-sensor flags that a run file replaces.
constexpr std::initializer_list<const char*> kSensorFlags = {
    "--source", "--config", "--sn", "--udp", "--udp-items", "--udp-progress", "--allow-zero-under-load", "--record",
    "--record-images", "--overwrite", "--ros2", "--ros2-reliable", "--ros2-image", "--ros2-frame-id",
    "--reference-frames", "--weight", "--support-resolve", "--gains",
    "--recompute-forces", "--drift", "--drift-time-constant-s", "--width", "--height", "--fps", "--exposure",
    "--pixel-format", "--speed"};

}  // namespace

void RegisterRun(CLI::App& app) {
  auto a = std::make_shared<RunArgs>();
  SensorRunSpec& sensor = a->sensor;
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Camera (or video, image folder, twin dataset) to 3D markers, displacements and forces, "
      "every frame; or a recording's frames replayed (tac3d's or the vendor's); several sensors with "
      "--run-file");
  cmd->add_option("--source", sensor.source,
                  "camera:N, /dev/videoN, a video file, an image folder, dataset:DIR, "
                  "recording:FILE (replays its frames), or vendor:DIR (replays a recording of the "
                  "vendor's software: its <SN> folder, or the folder of one or several; "
                  "docs/real-sensors.md)");
  cmd->add_option("--run-file", a->run_file,
                  "several sensors in one process, each on its thread (YAML; docs/pipeline.md)");
  cmd->add_option("--config", sensor.config, "sensor YAML (default: the built-in prototype)");
  cmd->add_option("--cache,--cache-dir", a->cache_dir, "directory of cached compliance models")->capture_default_str();
  cmd->add_option("--sn", sensor.sn,
                  "the sensor's serial number in the stream (default: an imported sensor's own, from "
                  "its config; else " + sensor.sn + "; a replay: the recorded one)");
  cmd->add_option("--udp", sensor.outputs.udp, "stream the Tac3D protocol to HOST:PORT");
  cmd->add_option("--udp-items", sensor.outputs.udp_items,
                  "with --udp, tac3d's extra items after the vendor's six: NAME,NAME,... of "
                  "3D_Normals, SlipState, SlipFraction, Friction, FrictionSigma, "
                  "SlipMargin, or all");
  cmd->add_flag("--udp-progress", sensor.outputs.udp_progress,
                "with --udp, also send the frames taken while the reference is (re)taken "
                "(InitializeProgress < 100; PyTac3D 3.3.0-p1 stops at the first)");
  cmd->add_flag("--allow-zero-under-load", sensor.outputs.allow_zero_under_load,
                "take a $C (zero) from the client or the viewer while the sensor is loaded (a marker "
                "displaced > 0.1 mm), with a warning; by default it is refused, as it would offset "
                "every later reading");
  cmd->add_option("--record", sensor.outputs.record, "record the frames to this file (crash-safe)");
  cmd->add_flag("--record-images", sensor.outputs.record_images, "record the raw camera images too (with --record)");
  cmd->add_flag("--overwrite", sensor.outputs.overwrite, "replace the --record file if it exists");
  cmd->add_option("--ros2", sensor.outputs.ros2,
                  "publish ROS 2 topics NAMESPACE/wrench, /markers, /status and take a zero on NAMESPACE/zero, "
                  "for ROS 2 nodes without any tac3d package (docs/ros2.md); domain ROS_DOMAIN_ID, DDS "
                  "config CYCLONEDDS_URI");
  cmd->add_flag("--ros2-reliable", sensor.outputs.ros2_reliable,
                "with --ros2, ROS 2's default QoS (reliable, keep-last 10) instead of the sensor-data profile "
                "(best effort, keep-last 5)");
  cmd->add_flag("--ros2-image", sensor.outputs.ros2_image,
                "with --ros2, also publish NAMESPACE/image, the camera frame as PNG (sensor_msgs/CompressedImage)");
  cmd->add_option("--ros2-frame-id", sensor.outputs.ros2_frame_id,
                  "with --ros2, the messages' frame_id (default: tac3d_<SN>)");
  cmd->add_flag("--json", a->json, "print each frame's summary as a JSON line");
  cmd->add_option("--reference-frames", sensor.reference_frames, "static frames taken as the reference")
      ->capture_default_str();
  cmd->add_option("--weight", a->weight,
                  "Tikhonov weight w of the force inverse, (mm/N)^2 (default: the sensor's; 0.05)");
  cmd->add_option("--support-resolve", a->support_resolve,
                  "re-solve the forces on the contact's support: on or off (default: on for the built-in "
                  "prototype, off for an imported sensor, as `tac3d eval vendor` checks it)")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_option("--gains", a->gains, "force gains Cx Cy Cz")->expected(3);
  cmd->add_flag("--recompute-forces", sensor.recompute_forces,
                "with recording:FILE or vendor:DIR: compute the forces anew from the recorded displacements "
                "through the inverse of --config's sensor (e.g. after a recalibration)");
  AddDriftOption(cmd, &sensor.drift.mode,
                 "drift at rest: off, flag (the default: drift_at_rest) or rezero (tracked out of "
                 "the reference; docs/pipeline.md)");
  cmd->add_option("--drift-time-constant-s", sensor.drift.time_constant_s,
                  "time constant of the drift estimate at rest, s")
      ->capture_default_str();
  cmd->add_option("--max-frames", a->max_frames,
                  "stop after this many frames (0: until the source ends); per sensor with --run-file");
  cmd->add_option("--width", sensor.camera.width, "camera width (default: the sensor config's)");
  cmd->add_option("--height", sensor.camera.height, "camera height (default: the sensor config's)");
  cmd->add_option("--fps", sensor.camera.fps, "camera frame rate")->capture_default_str();
  cmd->add_option("--exposure", sensor.exposure, "camera exposure (driver units; default automatic)");
  cmd->add_option("--pixel-format", sensor.camera.pixel_format,
                  "camera pixel format, a V4L2 code such as MJPG or YUYV (default: the driver's choice; "
                  "a 1920 x 1080 USB camera at 30 fps needs MJPG)");
  cmd->add_option("--speed", a->speed,
                  "recording:FILE and vendor:DIR pace: 1 recorded, 2 twice as fast, 0 as fast as possible; "
                  "with dataset:DIR, paces it by its timestamps (default there: as fast as possible)")
      ->capture_default_str();
  cmd->add_option("--web", a->viewer.web,
                  "serve the live viewer on HOST:PORT, e.g. 127.0.0.1:8080 (docs/viewer.md)");
  cmd->add_option("--web-root", a->viewer.web_root, "the viewer page's folder (default: the built one)");
  cmd->add_option("--web-hold", a->viewer.web_hold_s,
                  "after the source ends keep the viewer up this many seconds (-1: until Ctrl-C)");
  cmd->callback([a, cmd] {
    if (!a->run_file.empty()) {
      RefuseOptions(*cmd, kSensorFlags, "is given per sensor in the run file (--run-file)");
      return RunFile(*a);
    }
    if (a->sensor.source.empty()) throw Error("run: --source or --run-file is required");
    SetForceOptions(*a, *cmd);
    if (runtime::RecordingSourcePath(a->sensor.source) || runtime::VendorSourcePath(a->sensor.source)) {
      RefuseOptions(*cmd,
                    {"--reference-frames", "--drift", "--drift-time-constant-s", "--width", "--height", "--fps",
                     "--exposure", "--pixel-format"},
                    "does not apply to a recording: its frames were computed when it was recorded");
      if (!a->sensor.recompute_forces) {
        RefuseOptions(*cmd, {"--config", "--cache", "--weight", "--support-resolve", "--gains"},
                      "applies to a recording with --recompute-forces only: without it its frames are "
                      "replayed as they were computed");
      }
      return RunReplay(*a, /*replace_sn=*/cmd->count("--sn") > 0);
    }
    RefuseOptions(*cmd, {"--recompute-forces"}, "applies to --source recording:FILE or vendor:DIR only");
    if (a->sensor.source.rfind("dataset:", 0) == 0) {
      if (cmd->count("--speed") > 0) a->sensor.speed = a->speed;
    } else {
      RefuseOptions(*cmd, {"--speed"}, "applies to --source recording:FILE, vendor:DIR or dataset:DIR only");
    }
    Run(*a, /*sn_given=*/cmd->count("--sn") > 0);
  });
}

}  // namespace tac3d::cli
