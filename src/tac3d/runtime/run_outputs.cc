#include "tac3d/runtime/run_outputs.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/json_number.h"
#include "tac3d/web/web_server.h"

namespace tac3d::runtime {
namespace {

std::atomic<bool> g_stop{false};

// HOST and PORT of "HOST:PORT"; `flag` and `example` name them in the message.
std::pair<std::string, std::uint16_t> ParseHostPort(const std::string& host_port,
                                                    const char* flag,
                                                    const char* example,
                                                    int min_port = 1) {
  const size_t colon = host_port.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    throw Error(fmt::format("{} '{}': expected HOST:PORT, e.g. {}", flag, host_port, example));
  }
  int port = -1;
  try {
    size_t used = 0;
    port = std::stoi(host_port.substr(colon + 1), &used);
    if (used != host_port.size() - colon - 1) port = -1;
  } catch (const std::exception&) {
  }
  if (port < min_port || port > 65535)
    throw Error(fmt::format("{} '{}': the port must be {}-65535", flag, host_port, min_port));
  return {host_port.substr(0, colon), static_cast<std::uint16_t>(port)};
}

UdpSenderOptions ParseUdp(const FrameOutputArgs& args) {
  UdpSenderOptions options;
  std::tie(options.host, options.port) = ParseHostPort(args.udp, "--udp", "127.0.0.1:9988");
  ParseExtraItems(args.udp_items, "--udp-items");
  options.stream = {.items = args.udp_items, .send_initializing = args.udp_progress};
  return options;
}

// The viewer page's folder: --web-root, else $TAC3D_WEB_ROOT, else the build's, else the
// installed one.
std::string WebRoot(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* env = std::getenv("TAC3D_WEB_ROOT"); env && *env) return env;
  std::error_code ec;
  if (std::filesystem::is_directory(TAC3D_BUILD_WEB_ROOT, ec)) return TAC3D_BUILD_WEB_ROOT;
  return TAC3D_INSTALL_WEB_ROOT;
}

WebServerOptions ParseWeb(const FrameOutputArgs& args) {
  WebServerOptions options;
  // Port 0 (a free one) is allowed: the chosen port is printed.
  std::tie(options.host, options.port) = ParseHostPort(args.web, "--web", "127.0.0.1:8080", 0);
  options.root = WebRoot(args.web_root);
  return options;
}

nlohmann::json Summary(const TactileFrame& f) {
  int valid = 0, contact = 0;
  for (int i = 0; i < f.num_markers(); ++i) {
    valid += f.valid[i];
    contact += f.contact[i];
  }
  const auto v = [](const Eigen::Vector3d& x) { return nlohmann::json{x.x(), x.y(), x.z()}; };
  return {{"sn", f.sn},
          {"index", f.index},
          {"timestamp_s", f.timestamp_s},
          {"initialize_progress", f.initialize_progress},
          {"flags", FrameFlagNames(f.flags)},
          {"valid_markers", valid},
          {"contact_markers", contact},
          {"resultant_force_n", v(f.resultant_force_n)},
          {"resultant_moment_nmm", v(f.resultant_moment_nmm)},
          {"slip_state", SlipStateName(f.slip.state)},
          {"slip_fraction", FiniteOrNull(f.slip.fraction)},
          {"friction", FiniteOrNull(f.slip.friction)},
          {"friction_sigma", FiniteOrNull(f.slip.friction_sigma)},
          {"slip_margin", FiniteOrNull(f.slip.margin)},
          {"slip_margin_sigma", FiniteOrNull(f.slip.margin_sigma)},
          {"least_normal_force_n", FiniteOrNull(f.slip.least_normal_force_n)}};
}

}  // namespace

void FrameOutputArgs::Validate(const std::vector<std::string>& inputs) const {
  if (record_images && record.empty()) throw Error("--record-images needs --record FILE");
  if (overwrite && record.empty()) throw Error("--overwrite needs --record FILE");
  if (udp.empty() && !udp_items.empty()) throw Error("--udp-items needs --udp HOST:PORT");
  if (udp.empty() && udp_progress) throw Error("--udp-progress needs --udp HOST:PORT");
  if (!udp.empty()) ParseUdp(*this);
  if (!record.empty()) CheckOutputFile(record, "--record", {}, inputs);
  if (!web.empty()) ParseWeb(*this).Validate();
  if (!std::isfinite(web_hold_s)) {
    throw Error(fmt::format("--web-hold {} must be a number of seconds (-1: until Ctrl-C)", web_hold_s));
  }
  if (web.empty() && web_hold_s != 0) throw Error("--web-hold needs --web HOST:PORT");
  if (web.empty() && !web_root.empty()) throw Error("--web-root needs --web HOST:PORT");
  if (ros2.empty() && (ros2_reliable || ros2_image || !ros2_frame_id.empty())) {
    throw Error("--ros2-reliable, --ros2-image and --ros2-frame-id need --ros2 NAMESPACE");
  }
  if (!ros2.empty()) Ros2Options(*this).Validate();
}

Ros2PublisherOptions Ros2Options(const FrameOutputArgs& args) {
  return {.ns = args.ros2, .reliable = args.ros2_reliable, .image = args.ros2_image, .frame_id = args.ros2_frame_id};
}

std::shared_ptr<WebServer> OpenViewer(const FrameOutputArgs& args, WebApiHandler api) {
  TAC3D_DEMAND(!args.web.empty());
  WebServerOptions options = ParseWeb(args);
  options.api = std::move(api);
  auto viewer = std::make_shared<WebServer>(options);
  std::fprintf(stderr, "viewer on http://%s:%u/ (page from %s)\n", options.host.c_str(),
               static_cast<unsigned>(viewer->port()), options.root.c_str());
  return viewer;
}

FrameOutputs::FrameOutputs(const FrameOutputArgs& args, std::shared_ptr<WebServer> shared_viewer)
    : args_(args), web_(std::move(shared_viewer)) {
  TAC3D_DEMAND(!(web_ && !args.web.empty()));
  args.Validate();
  if (!args.udp.empty()) {
    sender_.emplace(ParseUdp(args));
    std::fprintf(stderr,
                 "streaming to %s%s (commands on %s)\n",
                 sender_->destination().ToString().c_str(),
                 args.sn.empty() ? "" : (" as SN " + args.sn).c_str(),
                 sender_->local_endpoint().ToString().c_str());
  }
  if (!args.record.empty()) recorder_.emplace(args.record, RecordingWriterOptions{.overwrite = args.overwrite});
  if (!args.ros2.empty()) {
    ros2_ = std::make_unique<Ros2Publisher>(Ros2Options(args));
    std::fprintf(stderr, "%spublishing ROS 2 topics %s/{wrench,markers,status%s} (%s QoS), zero on %s/zero\n",
                 args.sn.empty() ? "" : (args.sn + ": ").c_str(), ros2_->topic_namespace().c_str(),
                 args.ros2_image ? ",image" : "", args.ros2_reliable ? "reliable" : "sensor-data (best effort)",
                 ros2_->topic_namespace().c_str());
  }
  if (!args.web.empty()) web_ = OpenViewer(args);
}

FrameOutputs::~FrameOutputs() = default;

void FrameOutputs::Emit(const TactileFrame& frame, const cv::Mat& image, const MarkerObservation* markers) {
  if (recorder_) recorder_->Write(frame, args_.record_images ? image : cv::Mat());
  if (sender_) sender_->Send(frame);
  if (ros2_) ros2_->Publish(frame, image);
  if (web_) web_->Publish(frame, image, markers);
  // Flushed line by line: a reader on a pipe gets each frame at once, and a killed run has
  // printed every frame it recorded.
  if (args_.json) {
    // One line at a time: the sensors of a run file print from their own threads.
    static std::mutex stdout_mutex;
    const std::string line = Summary(frame).dump();
    std::lock_guard lock(stdout_mutex);
    WriteLineFlushed(stdout, line);
  }
}

std::optional<SensorCommand> FrameOutputs::PollCommand() {
  if (web_ && web_->TakeZeroRequest(args_.sn)) return SensorCommand::kZero;
  if (ros2_ && ros2_->TakeZeroRequest()) return SensorCommand::kZero;
  return sender_ ? sender_->PollCommand() : std::nullopt;
}

ZeroLoad MeasureZeroLoad(const TactileFrame& frame) {
  ZeroLoad load;
  load.force_n = frame.resultant_force_n.norm();
  for (int i = 0; i < frame.num_markers(); ++i) {
    if (frame.valid[i]) load.max_displacement_mm = std::max(load.max_displacement_mm, frame.displacements_mm[i].norm());
  }
  load.under_load = load.max_displacement_mm > kMaxZeroDisplacementMm;
  return load;
}

bool FrameOutputs::AcceptZero(const TactileFrame& last) const {
  const ZeroLoad load = MeasureZeroLoad(last);
  if (!load.under_load) return true;
  const std::string what = fmt::format(
      "|F| = {:.2f} N, a marker displaced {:.3f} mm (more than {} mm) at frame {}", load.force_n,
      load.max_displacement_mm, kMaxZeroDisplacementMm, last.index);
  const std::string sn = args_.sn.empty() ? "" : args_.sn + ": ";
  if (args_.allow_zero_under_load) {
    std::fprintf(stderr, "%swarning: zero taken under load (--allow-zero-under-load): %s; every later "
                 "reading is offset by this load\n", sn.c_str(), what.c_str());
    return true;
  }
  std::fprintf(stderr, "%srefused $C (zero) under load: %s. Zeroing now would offset every later reading "
               "by this load: zero at rest (nothing touching the sensor), or run with "
               "--allow-zero-under-load\n", sn.c_str(), what.c_str());
  return false;
}

void FrameOutputs::HoldWeb() { HoldViewer(web_.get(), args_.web_hold_s); }

void HoldViewer(const WebServer* viewer, double hold_s) {
  if (viewer == nullptr || hold_s == 0 || g_stop) return;
  StopSignals signals;
  std::fprintf(stderr, "the source ended; the viewer stays up %s\n",
               hold_s < 0 ? "until Ctrl-C" : fmt::format("{} s", hold_s).c_str());
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(hold_s);
  while (!g_stop && (hold_s < 0 || std::chrono::steady_clock::now() < end)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

StopSignals::StopSignals() {
  std::signal(SIGINT, [](int) { g_stop = true; });
  std::signal(SIGTERM, [](int) { g_stop = true; });
}

StopSignals::~StopSignals() {
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
}

std::atomic<bool>& StopSignals::flag() { return g_stop; }

std::string FrameOutputs::RecordedNote() const {
  std::string note;
  if (sender_) {
    note += fmt::format(", {} streamed", sender_->frames_sent());
    if (sender_->frames_withheld() > 0) {
      note += fmt::format(" ({} initialising withheld: --udp-progress sends them)", sender_->frames_withheld());
    }
  }
  if (recorder_) note += fmt::format(", {} recorded to {}", recorder_->frames_written(), args_.record);
  if (ros2_) {
    const Ros2PublisherStats s = ros2_->stats();
    note += fmt::format(", {} published on ROS 2 under {}", s.frames, ros2_->topic_namespace());
    if (s.failed_writes > 0) note += fmt::format(" ({} samples not taken by a lagging reader)", s.failed_writes);
  }
  if (web_) {
    const WebServerStats s = web_->stats();
    note += fmt::format(", viewer: {} messages sent, {} skipped, {} stalled clients dropped",
                        s.messages_sent, s.sends_skipped, s.clients_dropped);
  }
  return note;
}

FrameLoopCounts FrameLoop(FrameOutputs& outputs,
                          long max_frames,
                          const std::atomic<bool>& stop,
                          const FrameProducer& produce,
                          const ZeroHandler& on_zero) {
  FrameLoopCounts counts;
  while (!stop && !counts.quit && (max_frames <= 0 || counts.emitted < max_frames)) {
    ProducedFrame out;
    const Produced produced = produce(stop, out);
    if (produced == Produced::kEnd) break;
    if (produced == Produced::kSkipped) {
      ++counts.skipped;
      continue;
    }
    TAC3D_DEMAND(out.frame != nullptr);
    ++counts.emitted;
    outputs.Emit(*out.frame, out.image != nullptr ? *out.image : cv::Mat(), out.markers);
    while (const std::optional<SensorCommand> command = outputs.PollCommand()) {
      if (*command == SensorCommand::kZero &&
          (!on_zero.retakes_reference || outputs.AcceptZero(*out.frame))) {
        on_zero.zero();
      }
      if (*command == SensorCommand::kStop) counts.quit = true;
    }
  }
  return counts;
}

FrameLoopCounts RunFrameLoop(FrameOutputs& outputs,
                             long max_frames,
                             const FrameProducer& produce,
                             const ZeroHandler& on_zero) {
  g_stop = false;
  StopSignals signals;
  const FrameLoopCounts counts = FrameLoop(outputs, max_frames, g_stop, produce, on_zero);
  if (counts.quit) g_stop = true;
  return counts;
}

std::optional<std::string> RecordingSourcePath(const std::string& source) {
  constexpr std::string_view kPrefix = "recording:";
  if (source.rfind(kPrefix, 0) != 0) return std::nullopt;
  return source.substr(kPrefix.size());
}

std::optional<std::string> VendorSourcePath(const std::string& source) {
  constexpr std::string_view kPrefix = "vendor:";
  if (source.rfind(kPrefix, 0) != 0) return std::nullopt;
  return source.substr(kPrefix.size());
}

}  // namespace tac3d::runtime
