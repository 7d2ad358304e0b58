// `tac3d recording info|export` and the replay behind `tac3d run --source recording:FILE`
// (docs/recording.md).

#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "run_outputs.h"
#include "sensor_stream.h"
#include "tac3d/io/recording_export.h"
#include "tac3d/record/recording_info.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

nlohmann::json ToJson(const RecordingInfo& info) {
  const auto grids = [](const std::vector<RecordingInfo::Grid>& gs) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& g : gs) out.push_back({{"rows", g.rows}, {"cols", g.cols}});
    return out;
  };
  nlohmann::json flags = nlohmann::json::object();
  for (std::size_t i = 0; i < std::size(kAllFrameFlags); ++i) {
    flags[FrameFlagName(kAllFrameFlags[i])] = info.flag_frames[i];
  }
  return {{"path", info.path},
          {"file_bytes", info.file_bytes},
          {"frames", info.frames},
          {"first_index", info.first_index},
          {"last_index", info.last_index},
          {"index_gaps", info.index_gaps},
          {"first_timestamp_s", info.first_timestamp_s},
          {"last_timestamp_s", info.last_timestamp_s},
          {"timestamps_backwards", info.timestamps_backwards},
          {"duration_s", info.duration_s()},
          {"mean_fps", info.mean_fps()},
          {"sns", info.sns},
          {"grids", grids(info.grids)},
          {"frames_with_image", info.frames_with_image},
          {"image_sizes", grids(info.image_sizes)},
          {"flag_frames", flags},
          {"unflagged_frames", info.unflagged_frames},
          {"status", RecordingStatusName(info.status)},
          {"message", info.message},
          {"good_bytes", info.good_bytes},
          {"tail_bytes", info.tail_bytes()}};
}

// After the good frames were used: a truncated file (a writer killed mid-record) is a warning,
// a corrupt one an error.
void ReportEnd(RecordingStatus status, const std::string& message, const std::string& done) {
  if (status == RecordingStatus::kTruncated) {
    std::fprintf(stderr, "tac3d: warning: %s (%s)\n", message.c_str(), done.c_str());
  } else if (status == RecordingStatus::kCorrupt) {
    throw Error(fmt::format("{} ({})", message, done));
  }
}

struct InfoArgs {
  std::string path;
  bool json = false;
};

struct ExportArgs {
  std::string path;
  std::string out;
  std::string format = "npy";
  bool overwrite = false;
};

void Info(const InfoArgs& a) {
  const RecordingInfo info = ReadRecordingInfo(a.path);
  if (a.json) {
    std::printf("%s\n", ToJson(info).dump(2).c_str());
  } else {
    std::printf("%s", info.FullReport().c_str());
  }
}

void Export(const ExportArgs& a) {
  const RecordingExportResult result = ExportRecording(
      a.path, a.out, {.format = ParseRecordingExportFormat(a.format), .overwrite = a.overwrite});
  std::printf("exported %lld frames of %d x %d markers to %s:",
              static_cast<long long>(result.frames),
              result.rows,
              result.cols,
              a.out.c_str());
  for (const std::string& file : result.files) {
    const auto slash = file.find_last_of('/');
    std::printf(" %s", slash == std::string::npos ? file.c_str() : file.c_str() + slash + 1);
  }
  std::printf("\n");
  ReportEnd(result.status,
            result.message,
            fmt::format("the {} frames before it were exported", result.frames));
}

}  // namespace

void RunRecording(const RecordingRunArgs& args) {
  SensorRunSpec spec;
  spec.speed = args.speed;
  if (args.sn) spec.sn = *args.sn;
  const std::unique_ptr<SensorStream> stream = OpenRecordingStream(args.path, spec, args.sn.has_value());
  FrameOutputArgs output_args = args.outputs;
  if (args.sn) output_args.sn = *args.sn;
  FrameOutputs outputs(output_args);
  stream->Start({.epoch = std::chrono::steady_clock::now(), .common = false});
  const FrameLoopCounts counts = RunFrameLoop(
      outputs,
      args.max_frames,
      [&](const std::atomic<bool>& stop, ProducedFrame& out) { return stream->Next(stop, out); },
      [&] { stream->Zero(); });
  std::fprintf(stderr,
               "%ld frames replayed from %s%s\n",
               counts.emitted,
               args.path.c_str(),
               outputs.RecordedNote().c_str());
  outputs.HoldWeb();
  const StreamEnd end = stream->End(counts.emitted);
  if (!end.warning.empty()) std::fprintf(stderr, "tac3d: warning: %s\n", end.warning.c_str());
  if (!end.failure.empty()) throw Error(end.failure);
}

void RegisterRecording(CLI::App& app) {
  CLI::App* recording =
      app.add_subcommand("recording",
                         "Inspect or export a recording (tac3d run --record); replay one with "
                         "tac3d run --source recording:FILE");
  recording->require_subcommand(1);

  auto info = std::make_shared<InfoArgs>();
  CLI::App* info_cmd = recording->add_subcommand("info",
                                                 "Frames, duration, SN, marker grid, images, flags "
                                                 "and how the file ends (truncated, corrupt)");
  info_cmd->add_option("FILE", info->path, "the recording")->required();
  info_cmd->add_flag("--json", info->json, "print JSON");
  info_cmd->callback([info] { Info(*info); });

  auto ex = std::make_shared<ExportArgs>();
  CLI::App* export_cmd = recording->add_subcommand(
      "export",
      "The good frames as .npy arrays (numpy) or CSV tables, one file per field or table");
  export_cmd->add_option("FILE", ex->path, "the recording")->required();
  export_cmd->add_option("--out", ex->out, "output folder (created if missing)")->required();
  export_cmd->add_option("--format", ex->format, "npy or csv")
      ->check(CLI::IsMember({"npy", "csv"}))
      ->capture_default_str();
  export_cmd->add_flag("--overwrite", ex->overwrite, "replace files already in the output folder");
  export_cmd->callback([ex] { Export(*ex); });
}

}  // namespace tac3d::cli
