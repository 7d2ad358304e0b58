#include "run_outputs.h"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::cli {
namespace {

std::atomic<bool> g_stop{false};

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
  if (port < 1 || port > 65535)
    throw Error(fmt::format("--udp '{}': the port must be 1-65535", host_port));
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
  // NaN (no contact, not in gross slip) as null.
  const auto number = [](double x) {
    return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json();
  };
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
          {"slip_fraction", number(f.slip.fraction)},
          {"friction", number(f.slip.friction)},
          {"friction_sigma", number(f.slip.friction_sigma)}};
}

}  // namespace

void FrameOutputArgs::Validate() const {
  if (record_images && record.empty()) throw Error("--record-images needs --record FILE");
  if (overwrite && record.empty()) throw Error("--overwrite needs --record FILE");
  if (!udp.empty()) ParseUdp(udp);
  if (!record.empty()) CheckOutputFile(record, "--record");
}

FrameOutputs::FrameOutputs(const FrameOutputArgs& args) : args_(args) {
  args.Validate();
  if (!args.udp.empty()) {
    sender_.emplace(ParseUdp(args.udp));
    std::fprintf(stderr,
                 "streaming to %s%s (commands on %s)\n",
                 sender_->destination().ToString().c_str(),
                 args.sn.empty() ? "" : (" as SN " + args.sn).c_str(),
                 sender_->local_endpoint().ToString().c_str());
  }
  if (!args.record.empty()) recorder_.emplace(args.record, RecordingWriterOptions{.overwrite = args.overwrite});
}

void FrameOutputs::Emit(const TactileFrame& frame, const cv::Mat& image) {
  if (recorder_) recorder_->Write(frame, args_.record_images ? image : cv::Mat());
  if (sender_) sender_->Send(frame);
  // Flushed line by line: a reader on a pipe gets each frame at once, and a killed run has
  // printed every frame it recorded.
  if (args_.json) WriteLineFlushed(stdout, Summary(frame).dump());
}

std::optional<SensorCommand> FrameOutputs::PollCommand() {
  return sender_ ? sender_->PollCommand() : std::nullopt;
}

std::string FrameOutputs::RecordedNote() const {
  return recorder_ ? fmt::format(", {} recorded to {}", recorder_->frames_written(), args_.record)
                   : "";
}

FrameLoopCounts RunFrameLoop(FrameOutputs& outputs,
                             long max_frames,
                             const FrameProducer& produce,
                             const std::function<void()>& on_zero) {
  g_stop = false;
  std::signal(SIGINT, [](int) { g_stop = true; });
  std::signal(SIGTERM, [](int) { g_stop = true; });
  FrameLoopCounts counts;
  try {
    while (!g_stop && (max_frames <= 0 || counts.emitted < max_frames)) {
      const TactileFrame* frame = nullptr;
      const cv::Mat* image = nullptr;
      const Produced produced = produce(g_stop, frame, image);
      if (produced == Produced::kEnd) break;
      if (produced == Produced::kSkipped) {
        ++counts.skipped;
        continue;
      }
      TAC3D_DEMAND(frame != nullptr);
      ++counts.emitted;
      outputs.Emit(*frame, image != nullptr ? *image : cv::Mat());
      while (const std::optional<SensorCommand> command = outputs.PollCommand()) {
        if (*command == SensorCommand::kZero) on_zero();
        if (*command == SensorCommand::kStop) g_stop = true;
      }
    }
  } catch (...) {
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    throw;
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  return counts;
}

std::optional<std::string> RecordingSourcePath(const std::string& source) {
  constexpr std::string_view kPrefix = "recording:";
  if (source.rfind(kPrefix, 0) != 0) return std::nullopt;
  return source.substr(kPrefix.size());
}

void RefuseOptions(const CLI::App& cmd,
                   std::initializer_list<const char*> names,
                   const std::string& why) {
  for (const char* name : names) {
    if (cmd.count(name) > 0) throw Error(fmt::format("{} {}", name, why));
  }
}

}  // namespace tac3d::cli
