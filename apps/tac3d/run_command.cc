#include <chrono>
#include <map>
#include <cstdio>
#include <memory>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "run_outputs.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

// Camera options whose width and height (0) are taken from the sensor config.
CameraSourceOptions CameraWithSensorResolution() {
  CameraSourceOptions camera;
  camera.width = 0;
  camera.height = 0;
  return camera;
}

struct RunArgs {
  std::string source;
  std::string config;
  std::string cache_dir = DefaultCacheDir();
  std::string sn = PipelineOptions{}.sn;
  std::string udp;
  std::string record;
  bool record_images = false;
  bool overwrite = false;
  bool json = false;
  int reference_frames = PipelineOptions{}.reference_frames;
  double weight = PipelineOptions{}.force.weight;
  DriftMode drift = PipelineOptions{}.drift.mode;
  double drift_time_constant_s = PipelineOptions{}.drift.time_constant_s;
  std::vector<double> gains = {1.0, 1.0, 1.0};
  long max_frames = 0;
  CameraSourceOptions camera = CameraWithSensorResolution();
  double exposure = 0.0;
  double speed = 1.0;  // a recording's replay, or a dataset's pace when given
  bool pace = false;   // --speed given with a dataset: source
  std::string web;
  std::string web_root;
  double web_hold_s = 0.0;
};

std::unique_ptr<FrameSource> OpenSource(const RunArgs& a, const SensorConfig& config) {
  if (a.source.rfind("dataset:", 0) == 0) return OpenTwinDataset(a.source.substr(8));
  CameraSourceOptions camera = a.camera;
  if (camera.width == 0) camera.width = config.camera.intrinsics.width;
  if (camera.height == 0) camera.height = config.camera.intrinsics.height;
  if (a.exposure > 0) camera.exposure = a.exposure;
  return OpenFrameSource(a.source, camera);
}

FrameOutputArgs OutputArgs(const RunArgs& a) {
  return {.udp = a.udp,
          .record = a.record,
          .record_images = a.record_images,
          .json = a.json,
          .sn = a.sn,
          .overwrite = a.overwrite,
          .web = a.web,
          .web_root = a.web_root,
          .web_hold_s = a.web_hold_s};
}

void Run(const RunArgs& a) {
  // Checked before the compliance model is loaded (or built, ~1 min).
  OutputArgs(a).Validate();
  const SensorConfig config = LoadSensorOrDefault(a.config);
  std::unique_ptr<FrameSource> source = OpenSource(a, config);
  std::fprintf(stderr, "source: %s\n", source->Describe().c_str());
  MakeDirectory(a.cache_dir);
  const fem::ComplianceCacheResult model =
      fem::LoadOrBuildComplianceModel(fem::BodyModelOptionsFromSensor(config), a.cache_dir, /*show_progress=*/true);
  PipelineOptions options;
  options.sn = a.sn;
  options.reference_frames = a.reference_frames;
  options.force.weight = a.weight;
  options.drift.mode = a.drift;
  options.drift.time_constant_s = a.drift_time_constant_s;
  if (a.gains.size() != 3) throw Error("--gains takes three numbers: Cx Cy Cz");
  options.force.gains = Eigen::Vector3d(a.gains[0], a.gains[1], a.gains[2]);
  Pipeline pipeline(config, model.model.h, model.model.marker_positions, options);

  FrameOutputs outputs(OutputArgs(a));
  Frame frame;
  TactileFrame out;
  std::string failure;
  const auto start = std::chrono::steady_clock::now();
  const FrameLoopCounts counts = RunFrameLoop(
      outputs, a.max_frames,
      [&](const std::atomic<bool>&, const TactileFrame*& produced, const cv::Mat*& image) {
        const ReadStatus status = source->Read(frame);
        if (status == ReadStatus::kEnd) return Produced::kEnd;
        if (status == ReadStatus::kFailed) {
          failure = source->last_error();
          return Produced::kEnd;
        }
        if (status == ReadStatus::kBadFrame) {
          std::fprintf(stderr, "skipped a bad frame: %s\n", source->last_error().c_str());
          return Produced::kSkipped;
        }
        if (a.pace && a.speed > 0) {
          std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                    std::chrono::duration<double>(frame.timestamp_s / a.speed)));
        }
        try {
          pipeline.Process(frame, out);
        } catch (const Error& e) {
          std::fprintf(stderr, "skipped frame %lld: %s\n", static_cast<long long>(frame.index),
                       e.what());
          return Produced::kSkipped;
        }
        produced = &out;
        image = &frame.image;
        return Produced::kFrame;
      },
      [&pipeline] { pipeline.RequestZero(); });
  std::fprintf(stderr, "%ld frames processed, %ld skipped%s\n", counts.emitted, counts.skipped,
               outputs.RecordedNote().c_str());
  outputs.HoldWeb();
  // The recording is complete up to the last frame; now say why the source ended.
  if (!failure.empty()) throw Error(fmt::format("the frame source failed: {}", failure));
}

}  // namespace

void RegisterRun(CLI::App& app) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Camera (or video, image folder, twin dataset) to 3D markers, displacements and forces, "
      "every frame; or a recording's frames replayed");
  cmd->add_option("--source", a->source,
                  "camera:N, /dev/videoN, a video file, an image folder, dataset:DIR, or "
                  "recording:FILE (replays its frames)")
      ->required();
  cmd->add_option("--config", a->config, "sensor YAML (default: the built-in prototype)");
  cmd->add_option("--cache", a->cache_dir, "directory of cached compliance models")->capture_default_str();
  cmd->add_option("--sn", a->sn, "the sensor's serial number in the stream")->capture_default_str();
  cmd->add_option("--udp", a->udp, "stream the Tac3D protocol to HOST:PORT");
  cmd->add_option("--record", a->record, "record the frames to this file (crash-safe)");
  cmd->add_flag("--record-images", a->record_images, "record the raw camera images too (with --record)");
  cmd->add_flag("--overwrite", a->overwrite, "replace the --record file if it exists");
  cmd->add_flag("--json", a->json, "print each frame's summary as a JSON line");
  cmd->add_option("--reference-frames", a->reference_frames, "static frames taken as the reference")
      ->capture_default_str();
  cmd->add_option("--weight", a->weight, "Tikhonov weight w, (mm/N)^2")->capture_default_str();
  cmd->add_option("--gains", a->gains, "force gains Cx Cy Cz")->expected(3);
  cmd->add_option("--drift", a->drift,
                  "drift at rest: off, flag (the default: drift_at_rest) or rezero (tracked out of the "
                  "reference; docs/pipeline.md)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, DriftMode>{
              {"off", DriftMode::kOff}, {"flag", DriftMode::kFlag}, {"rezero", DriftMode::kRezero}},
          CLI::ignore_case));
  cmd->add_option("--drift-time-constant", a->drift_time_constant_s,
                  "time constant of the drift estimate at rest, s")
      ->capture_default_str();
  cmd->add_option("--max-frames", a->max_frames, "stop after this many frames (0: until the source ends)");
  cmd->add_option("--width", a->camera.width, "camera width (default: the sensor config's)");
  cmd->add_option("--height", a->camera.height, "camera height (default: the sensor config's)");
  cmd->add_option("--fps", a->camera.fps, "camera frame rate")->capture_default_str();
  cmd->add_option("--exposure", a->exposure, "camera exposure (driver units; default automatic)");
  cmd->add_option("--speed", a->speed,
                  "recording:FILE pace: 1 recorded, 2 twice as fast, 0 as fast as possible; "
                  "with dataset:DIR, paces it by its timestamps (default there: as fast as possible)")
      ->capture_default_str();
  cmd->add_option("--web", a->web,
                  "serve the live viewer on HOST:PORT, e.g. 127.0.0.1:8080 (docs/viewer.md)");
  cmd->add_option("--web-root", a->web_root, "the viewer page's folder (default: the built one)");
  cmd->add_option("--web-hold", a->web_hold_s,
                  "after the source ends keep the viewer up this many seconds (-1: until Ctrl-C)");
  cmd->callback([a, cmd] {
    if (const std::optional<std::string> path = RecordingSourcePath(a->source)) {
      RefuseOptions(*cmd,
                    {"--config", "--cache", "--reference-frames", "--weight", "--gains", "--drift",
                     "--drift-time-constant", "--width",
                     "--height", "--fps", "--exposure"},
                    "does not apply to a recording: its frames were computed when it was recorded");
      return RunRecording({.path = *path,
                           .speed = a->speed,
                           .max_frames = a->max_frames,
                           .sn = cmd->count("--sn") > 0 ? std::optional(a->sn) : std::nullopt,
                           .outputs = {.udp = a->udp,
                                       .record = a->record,
                                       .record_images = a->record_images,
                                       .json = a->json,
                                       .sn = {},
                                       .overwrite = a->overwrite,
                                       .web = a->web,
                                       .web_root = a->web_root,
                                       .web_hold_s = a->web_hold_s}});
    }
    if (a->source.rfind("dataset:", 0) == 0) {
      a->pace = cmd->count("--speed") > 0;
    } else {
      RefuseOptions(*cmd, {"--speed"}, "applies to --source recording:FILE or dataset:DIR only");
    }
    Run(*a);
  });
}

}  // namespace tac3d::cli
