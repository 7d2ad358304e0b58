// `tac3d recording info|export` and the replay behind `tac3d run --source recording:FILE`
// (docs/recording.md).

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/io/recording_export.h"
#include "tac3d/mcap/recording_mcap.h"
#include "tac3d/record/recording_info.h"
#include "tac3d/reference_log/reference_log.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/vendor_frames.h"
#include "tac3d/vendor_formats/vendor_recording.h"

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
  std::string frame_id;
  bool overwrite = false;
};

// The vendor's recording folder of `tac3d recording export vendor:DIR --format mcap`.
constexpr std::string_view kVendorPrefix = "vendor:";

void Info(const InfoArgs& a) {
  const RecordingInfo info = ReadRecordingInfo(a.path);
  if (a.json) {
    std::printf("%s\n", ToJson(info).dump(2).c_str());
  } else {
    std::printf("%s", info.FullReport().c_str());
  }
}

// The vendor's layout (docs/real-sensors.md): <out>/<SN>/<field>.npy and overview.csv.
void ExportVendor(const ExportArgs& a) {
  CheckOutputFolder(a.out, "--out");
  RecordingReader reader(a.path);
  std::vector<TactileFrame> frames;
  while (std::optional<RecordedFrame> recorded = reader.Next()) frames.push_back(std::move(recorded->frame));
  const std::string done = fmt::format("the {} frames before it were exported", frames.size());
  if (reader.status() == RecordingStatus::kCorrupt) ReportEnd(reader.status(), reader.message(), done);
  const VendorRecording vendor = VendorRecordingOfFrames(frames);
  const std::string folder = a.out + "/" + vendor.serial_number;
  if (!a.overwrite && std::filesystem::exists(folder)) {
    throw Error(fmt::format("'{}' exists: give --overwrite to replace its files", folder));
  }
  WriteVendorRecording(vendor, a.out);
  std::printf("exported %lld frames of %lld markers to %s in the vendor's layout\n",
              static_cast<long long>(vendor.frames()), static_cast<long long>(vendor.markers()), folder.c_str());
  ReportEnd(reader.status(), reader.message(), done);
}

struct ImportArgs {
  std::string folder;
  std::string out;
  bool overwrite = false;
};

// `tac3d recording import`: a vendor recording as a tac3d recording.
void Import(const ImportArgs& a) {
  CheckOutputFile(a.out, "--out", {}, {a.folder});
  // A frame at a time: the recording's frames held at once took ~100 kB each.
  const VendorFrames frames(ReadVendorRecording(a.folder));
  const VendorRecording& vendor = frames.recording();
  RecordingWriter writer(a.out, {.overwrite = a.overwrite});
  for (std::int64_t f = 0; f < frames.frames(); ++f) writer.Write(frames.Frame(f));
  std::printf("imported %lld frames of %lld markers of sensor %s to %s\n", static_cast<long long>(vendor.frames()),
              static_cast<long long>(vendor.markers()), vendor.serial_number.c_str(), a.out.c_str());
}

// A ROS 2 bag in MCAP (docs/recording.md, "Export to MCAP"), of a recording or a vendor recording.
void ExportMcap(const ExportArgs& a) {
  const McapExportOptions options{.frame_id = a.frame_id, .overwrite = a.overwrite};
  McapExportResult result;
  std::optional<RecordingReader> reader;
  if (a.path.starts_with(kVendorPrefix)) {
    const std::string folder = a.path.substr(kVendorPrefix.size());
    // Read at the first frame, once the output was checked.
    std::optional<VendorFrames> frames;
    std::int64_t f = 0;
    result = ExportFramesToMcap(
        a.out,
        [&]() -> std::optional<RecordedFrame> {
          if (!frames) frames.emplace(ReadVendorRecording(folder));
          if (f == frames->frames()) return std::nullopt;
          return RecordedFrame{frames->Frame(f++), {}};
        },
        options, {folder});
  } else {
    reader.emplace(a.path);
    result = ExportFramesToMcap(a.out, [&] { return reader->Next(); }, options, {a.path});
  }
  std::printf("exported %lld frames to %s: %llu messages on %s\n", static_cast<long long>(result.frames),
              a.out.c_str(), static_cast<unsigned long long>(result.messages),
              fmt::format("{}", fmt::join(result.topics, " ")).c_str());
  if (reader) {
    ReportEnd(reader->status(), reader->message(), fmt::format("the {} frames before it were exported", result.frames));
  }
}

void Export(const ExportArgs& a) {
  if (a.format == "mcap") return ExportMcap(a);
  if (a.path.starts_with(kVendorPrefix)) {
    throw Error(fmt::format("'{}': a vendor recording exports only with --format mcap (`tac3d recording import` "
                            "makes a tac3d recording of it)",
                            a.path));
  }
  if (!a.frame_id.empty()) throw Error("--frame-id is for --format mcap");
  if (a.format == "vendor") return ExportVendor(a);
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
  if (result.images > 0) std::printf(", and %lld images in images/", static_cast<long long>(result.images));
  std::printf("\n");
  ReportEnd(result.status,
            result.message,
            fmt::format("the {} frames before it were exported", result.frames));
}

}  // namespace

struct PairsArgs {
  std::string path;
  std::string reference;
  std::string pairs_out;
  std::string presses_out;
  std::vector<double> time_offset;
  std::vector<double> gains_used;
  ReferenceJoinOptions options;
  bool json = false;
};

// `tac3d recording pairs`: the recording joined with a reference force sensor's log into the
// CSV files `tac3d calibrate-force --pairs / --presses` read.
void Pairs(const PairsArgs& args) {
  if (args.pairs_out.empty() && args.presses_out.empty()) {
    throw Error("recording pairs needs --pairs-out or --presses-out (or both)");
  }
  for (const std::string& out : {args.pairs_out, args.presses_out}) {
    if (!out.empty()) CheckOutputFile(out, "calibration CSV", {".csv"}, {args.path, args.reference});
  }
  ReferenceJoinOptions options = args.options;
  if (!args.time_offset.empty()) options.time_offset_s = args.time_offset[0];
  if (!args.gains_used.empty()) {
    options.gains_used = Eigen::Vector3d(args.gains_used[0], args.gains_used[1], args.gains_used[2]);
  }
  ValidateNamingFlags([&] { options.Validate(); },
                      {{"ReferenceJoinOptions: time_offset_s", "--time-offset"},
                       {"ReferenceJoinOptions: max_offset_s", "--max-offset"},
                       {"ReferenceJoinOptions: min_correlation", "--min-correlation"},
                       {"ReferenceJoinOptions: min_force_n", "--min-force"},
                       {"ReferenceJoinOptions: max_rate_n_per_s", "--max-rate"},
                       {"ReferenceJoinOptions: gains_used", "--gains-used"}});
  const ReferenceJoin join =
      JoinRecordingWithReference(args.path, LoadReferenceLog(args.reference), options);
  if (static_cast<int>(join.pairs.size()) < kMinForcePairs) {
    throw Error(fmt::format(
        "{} steady press frame(s) of {} (skipped: {} outside the log, {} under {} N, {} changing "
        "faster than {} N/s, {} flagged, {} with a marker lost): calibrate-force needs at least {}",
        join.pairs.size(), join.frames, join.skipped.outside_reference, join.skipped.below_force,
        options.min_force_n, join.skipped.changing, options.max_rate_n_per_s, join.skipped.flagged,
        join.skipped.invalid_markers, kMinForcePairs));
  }
  if (!args.pairs_out.empty()) WriteTextFileAtomically(args.pairs_out, ForcePairsToCsv(join.pairs));
  if (!args.presses_out.empty()) {
    WriteTextFileAtomically(args.presses_out, CalibrationPressesToCsv(join.presses));
  }
  if (args.json) {
    std::printf("%s\n", ToJson(join).dump(2).c_str());
    return;
  }
  std::printf(
      "offset %.4f s (%s; recording time = reference time + offset), force magnitudes correlate "
      "%.4f\n%zu steady press frames of %lld; skipped: %lld outside the log, %lld under %g N, "
      "%lld changing faster than %g N/s, %lld flagged, %lld with a marker lost\n",
      join.time_offset_s, join.offset_estimated ? "estimated" : "given", join.correlation,
      join.pairs.size(), static_cast<long long>(join.frames),
      static_cast<long long>(join.skipped.outside_reference),
      static_cast<long long>(join.skipped.below_force), options.min_force_n,
      static_cast<long long>(join.skipped.changing), options.max_rate_n_per_s,
      static_cast<long long>(join.skipped.flagged),
      static_cast<long long>(join.skipped.invalid_markers));
  if (join.recording_status != "complete") {
    std::fprintf(stderr, "tac3d: warning: the recording ends %s: %s (its earlier frames used)\n",
                 join.recording_status.c_str(), join.recording_message.c_str());
  }
  for (const std::string& out : {args.pairs_out, args.presses_out}) {
    if (!out.empty()) std::printf("wrote %s\n", out.c_str());
  }
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
      "The good frames as .npy arrays (numpy) or CSV tables, one file per field or table, in the vendor's "
      "recording layout (<out>/<SN>/<field>.npy), or as a ROS 2 bag in MCAP (Foxglove, ros2 bag play)");
  export_cmd->add_option("FILE", ex->path, "the recording (for --format mcap also vendor:DIR, a vendor recording)")
      ->required();
  export_cmd->add_option("--out", ex->out, "output folder (created if missing); for --format mcap the .mcap file")
      ->required();
  export_cmd->add_option("--format", ex->format, "npy, csv, vendor or mcap")
      ->check(CLI::IsMember({"npy", "csv", "vendor", "mcap"}))
      ->capture_default_str();
  export_cmd->add_option("--frame-id", ex->frame_id,
                         "--format mcap: the messages' header.frame_id (default tac3d_<SN>)");
  export_cmd->add_flag("--overwrite", ex->overwrite, "replace files already in the output folder");
  export_cmd->callback([ex] { Export(*ex); });

  auto import = std::make_shared<ImportArgs>();
  CLI::App* import_cmd = recording->add_subcommand(
      "import", "A vendor recording (Tac3D-Desktop, PyTac3D: <recording>/<SN>/<field>.npy) as a tac3d recording");
  import_cmd->add_option("DIR", import->folder, "the vendor's recording folder, or its <SN> folder")->required();
  import_cmd->add_option("--out", import->out, "the tac3d recording to write")->required();
  import_cmd->add_flag("--overwrite", import->overwrite, "replace the file if it exists");
  import_cmd->callback([import] { Import(*import); });

  auto pairs = std::make_shared<PairsArgs>();
  CLI::App* pairs_cmd = recording->add_subcommand(
      "pairs",
      "Join a recording with a reference force sensor's log (CSV t_s,fx_n,fy_n,fz_n, sensor "
      "frame) into the force pairs and presses tac3d calibrate-force fits (docs/calibrating-a-sensor.md)");
  pairs_cmd->add_option("FILE", pairs->path, "the recording")->required();
  pairs_cmd->add_option("--reference", pairs->reference, "the reference log CSV")->required();
  pairs_cmd->add_option("--pairs-out", pairs->pairs_out, "write force pairs (calibrate-force --pairs)");
  pairs_cmd->add_option("--presses-out", pairs->presses_out,
                        "write presses with displacements (calibrate-force --presses)");
  pairs_cmd->add_option("--time-offset", pairs->time_offset,
                        "recording time = reference time + this (s); default: estimated")
      ->expected(1);
  pairs_cmd->add_option("--max-offset", pairs->options.max_offset_s,
                        "the estimate's search range, +- (s)")
      ->capture_default_str();
  pairs_cmd->add_option("--min-correlation", pairs->options.min_correlation,
                        "the least correlation of the force magnitudes the estimate accepts")
      ->capture_default_str();
  pairs_cmd->add_option("--min-force", pairs->options.min_force_n,
                        "a frame is a press when the reference reads at least this (N)")
      ->capture_default_str();
  pairs_cmd->add_option("--max-rate", pairs->options.max_rate_n_per_s,
                        "... and changes no faster than this (N/s)")
      ->capture_default_str();
  pairs_cmd->add_option("--gains-used", pairs->gains_used,
                        "the gains the recording was made with (tac3d run --gains); default 1 1 1")
      ->expected(3);
  pairs_cmd->add_flag("--json", pairs->json, "print JSON");
  pairs_cmd->callback([pairs] { Pairs(*pairs); });
}

}  // namespace tac3d::cli
