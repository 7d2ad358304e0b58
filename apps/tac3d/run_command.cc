#include <atomic>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/util/file_io.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/protocol/udp_sender.h"
#include "tac3d/record/recording.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

std::atomic<bool> g_interrupted{false};

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
  std::vector<double> gains = {1.0, 1.0, 1.0};
  long max_frames = 0;
  CameraSourceOptions camera = CameraWithSensorResolution();
  double exposure = 0.0;
};

std::unique_ptr<FrameSource> OpenSource(const RunArgs& a, const SensorConfig& config) {
  if (a.source.rfind("dataset:", 0) == 0) return OpenTwinDataset(a.source.substr(8));
  CameraSourceOptions camera = a.camera;
  if (camera.width == 0) camera.width = config.camera.intrinsics.width;
  if (camera.height == 0) camera.height = config.camera.intrinsics.height;
  if (a.exposure > 0) camera.exposure = a.exposure;
  return OpenFrameSource(a.source, camera);
}

UdpSenderOptions ParseUdp(const std::string& host_port) {
  const size_t colon = host_port.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    throw Error(fmt::format("--udp '{}': expected HOST:PORT, e.g. 127.0.0.1:9988", host_port));
  }
  UdpSenderOptions options;
  options.host = host_port.substr(0, colon);
  int port = 0;
  try {
    port = std::stoi(host_port.substr(colon + 1));
  } catch (const std::exception&) {
  }
  if (port < 1 || port > 65535) throw Error(fmt::format("--udp '{}': the port must be 1-65535", host_port));
  options.port = static_cast<std::uint16_t>(port);
  return options;
}

nlohmann::json Summary(const TactileFrame& f) {
  int valid = 0, contact = 0;
  for (int i = 0; i < f.num_markers(); ++i) {
    valid += f.valid[i];
    contact += f.contact[i];
  }
  const auto v = [](const Eigen::Vector3d& x) { return nlohmann::json{x.x(), x.y(), x.z()}; };
  return {{"sn", f.sn},           {"index", f.index},
          {"timestamp_s", f.timestamp_s}, {"initialize_progress", f.initialize_progress},
          {"flags", FrameFlagNames(f.flags)}, {"valid_markers", valid},
          {"contact_markers", contact},   {"resultant_force_n", v(f.resultant_force_n)},
          {"resultant_moment_nmm", v(f.resultant_moment_nmm)}};
}

void Run(const RunArgs& a) {
  if (a.record_images && a.record.empty()) throw Error("--record-images needs --record FILE");
  if (a.overwrite && a.record.empty()) throw Error("--overwrite needs --record FILE");
  // Arguments that can fail are checked before the compliance model is loaded or built.
  if (!a.udp.empty()) ParseUdp(a.udp);
  if (!a.record.empty()) CheckOutputFile(a.record, "--record");
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
  if (a.gains.size() != 3) throw Error("--gains takes three numbers: Cx Cy Cz");
  options.force.gains = Eigen::Vector3d(a.gains[0], a.gains[1], a.gains[2]);
  Pipeline pipeline(config, model.model.h, model.model.marker_positions, options);

  std::optional<UdpSender> sender;
  if (!a.udp.empty()) {
    sender.emplace(ParseUdp(a.udp));
    std::fprintf(stderr, "streaming to %s as SN %s (commands on %s)\n", sender->destination().ToString().c_str(),
                 a.sn.c_str(), sender->local_endpoint().ToString().c_str());
  }
  std::optional<RecordingWriter> recorder;
  if (!a.record.empty()) recorder.emplace(a.record, RecordingWriterOptions{.overwrite = a.overwrite});

  g_interrupted = false;
  std::signal(SIGINT, [](int) { g_interrupted = true; });
  std::signal(SIGTERM, [](int) { g_interrupted = true; });
  Frame frame;
  TactileFrame out;
  long processed = 0, bad = 0;
  std::string failure;
  while (!g_interrupted && (a.max_frames <= 0 || processed < a.max_frames)) {
    const ReadStatus status = source->Read(frame);
    if (status == ReadStatus::kEnd) break;
    if (status == ReadStatus::kFailed) {
      failure = source->last_error();
      break;
    }
    if (status == ReadStatus::kBadFrame) {
      ++bad;
      std::fprintf(stderr, "skipped a bad frame: %s\n", source->last_error().c_str());
      continue;
    }
    try {
      pipeline.Process(frame, out);
    } catch (const Error& e) {
      ++bad;
      std::fprintf(stderr, "skipped frame %lld: %s\n", static_cast<long long>(frame.index), e.what());
      continue;
    }
    ++processed;
    if (recorder) recorder->Write(out, a.record_images ? frame.image : cv::Mat());
    if (sender) {
      sender->Send(out);
      while (const std::optional<SensorCommand> command = sender->PollCommand()) {
        if (*command == SensorCommand::kZero) pipeline.RequestZero();
        if (*command == SensorCommand::kStop) g_interrupted = true;
      }
    }
    if (a.json) WriteLineFlushed(stdout, Summary(out).dump());
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::fprintf(stderr, "%ld frames processed, %ld skipped%s\n", processed, bad,
               recorder ? fmt::format(", {} recorded to {}", recorder->frames_written(), a.record).c_str() : "");
  // The recording is complete up to the last frame; now say why the source ended.
  if (!failure.empty()) throw Error(fmt::format("the frame source failed: {}", failure));
}

}  // namespace

void RegisterRun(CLI::App& app) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand(
      "run", "Camera (or video, image folder, twin dataset) to 3D markers, displacements and forces, every frame");
  cmd->add_option("--source", a->source,
                  "camera:N, /dev/videoN, a video file, an image folder, or dataset:DIR")
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
  cmd->add_option("--max-frames", a->max_frames, "stop after this many frames (0: until the source ends)");
  cmd->add_option("--width", a->camera.width, "camera width (default: the sensor config's)");
  cmd->add_option("--height", a->camera.height, "camera height (default: the sensor config's)");
  cmd->add_option("--fps", a->camera.fps, "camera frame rate")->capture_default_str();
  cmd->add_option("--exposure", a->exposure, "camera exposure (driver units; default automatic)");
  cmd->callback([a] { Run(*a); });
}

}  // namespace tac3d::cli
