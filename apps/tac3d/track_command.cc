// `tac3d track`: a single-view marker sensor's markers tracked through a video, an image
// folder or a camera (docs/real-images.md).

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <regex>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/imagefile/image_write.h"
#include "tac3d/tracking/single_view_track.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/web/web_server.h"

namespace tac3d::cli {
namespace {

struct TrackArgs {
  std::string source;
  std::string grid;  // "RxC", empty: found in the reference frame
  std::int64_t reference = 0;
  std::string out;
  bool json = false;
  std::string overlay;
  std::string rest_frames;  // "A:B,C:D": frames without contact, for the jitter
};

std::pair<int, int> ParseGrid(const std::string& text) {
  std::smatch m;
  if (!std::regex_match(text, m, std::regex(R"((\d{1,4})[xX](\d{1,4}))")) || std::stoi(m[1]) < 1 ||
      std::stoi(m[2]) < 1) {
    throw Error(fmt::format("track: --grid '{}' must be ROWSxCOLS, such as 8x10", text));
  }
  if (std::stoi(m[1]) > kMaxMarkerGridSide || std::stoi(m[2]) > kMaxMarkerGridSide) {
    throw Error(fmt::format("track: --grid '{}': at most {} x {} markers", text, kMaxMarkerGridSide,
                            kMaxMarkerGridSide));
  }
  return {std::stoi(m[1]), std::stoi(m[2])};
}

// "A:B,C:D" into inclusive frame ranges.
std::vector<FrameRange> ParseRanges(const std::string& text) {
  std::vector<FrameRange> ranges;
  if (text.empty()) return ranges;
  const std::regex range(R"((\d+):(\d+))");
  const std::regex comma(",");
  for (std::sregex_token_iterator it(text.begin(), text.end(), comma, -1), end; it != end; ++it) {
    std::smatch m;
    const std::string part = *it;
    if (!std::regex_match(part, m, range)) {
      throw Error(fmt::format("track: --rest-frames '{}': '{}' must be FIRST:LAST, two frame numbers", text, part));
    }
    if (m[1].length() > 9 || m[2].length() > 9) {
      throw Error(fmt::format("track: --rest-frames '{}': '{}': a frame number has at most 9 digits", text, part));
    }
    if (std::stoll(m[1]) > std::stoll(m[2])) {
      throw Error(fmt::format("track: --rest-frames '{}': '{}' must be FIRST:LAST with FIRST <= LAST", text, part));
    }
    ranges.push_back({std::stoll(m[1]), std::stoll(m[2])});
  }
  return ranges;
}

void PrintSummary(const SingleViewTrackSummary& s, bool rest_frames) {
  std::printf("%s: grid %d x %d, pitch %.1f px, dots %.1f px in radius; reference frame %lld: %d markers "
              "tracked\n",
              s.source.c_str(), s.rows, s.cols, s.pitch_px, s.dot_radius_px, static_cast<long long>(s.reference_frame),
              s.reference_tracked);
  std::printf("%lld frames (%lld unreadable skipped); markers away from the border: %lld marker-frames, %lld of "
              "them not tracked; per frame at most %d cut by the border, %d estimated, %d lost; %d re-acquisitions\n",
              static_cast<long long>(s.frames), static_cast<long long>(s.bad_frames),
              static_cast<long long>(s.inside), static_cast<long long>(s.inside_untracked), s.max_cut,
              s.max_estimated, s.max_lost, s.reacquisitions);
  std::printf("largest move between frames %.2f px; moves over half the pitch (identity swaps) %d\n",
              s.max_step_px, s.swaps);
  std::printf("deepest press (the largest displacement) in frame %lld: largest %.2f px, mean %.2f px\n",
              static_cast<long long>(s.deepest_frame), s.deepest_max_px, s.deepest_mean_px);
  if (rest_frames) {
    std::printf("jitter over %d rest frames: %.3f px RMS in x, %.3f px in y (worst marker %.3f px)\n",
                s.rest_frames, s.jitter_x_px, s.jitter_y_px, s.jitter_max_px);
  }
}

// The frame's CSV rows.
void AppendCsv(const SingleViewTrackFrame& frame, const GridObservation& reference, int cols, std::string& csv) {
  auto number = [](double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : std::string(); };
  const GridObservation& o = frame.markers;
  for (int i = 0; i < static_cast<int>(o.state.size()); ++i) {
    const TrackedMarkerState state = TrackedStateOf(o, i);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const Eigen::Vector2d p = state == TrackedMarkerState::kLost ? Eigen::Vector2d(nan, nan) : o.estimate_uv[i];
    const Eigen::Vector2d& p0 = reference.estimate_uv[i];
    csv += fmt::format("{},{},{},{},{},{},{},{}\n", frame.index, i / cols, i % cols, number(p0.x()),
                       number(p0.y()), number(p.x()), number(p.y()), ToString(state));
  }
}

void Track(const TrackArgs& a) {
  if (a.source.empty()) throw Error("track: --source is required");
  if (a.reference < 0) throw Error(fmt::format("track: --reference {} must be >= 0", a.reference));
  SingleViewTrackOptions options;
  if (!a.grid.empty()) std::tie(options.rows, options.cols) = ParseGrid(a.grid);
  options.reference_frame = a.reference;
  options.rest_frames = ParseRanges(a.rest_frames);
  if (!a.out.empty()) CheckOutputFile(a.out, "--out", {}, {a.source});
  if (!a.overlay.empty()) MakeDirectory(a.overlay);
  SingleViewSourceTracker tracker(OpenSingleViewSource(a.source), options);
  const GridObservation& reference = tracker.reference();
  std::string csv = "frame,row,col,x0,y0,x,y,state\n";
  SingleViewTrackFrame frame;
  while (true) {
    const ReadStatus status = tracker.Next(frame);
    if (status == ReadStatus::kEnd) break;
    if (status == ReadStatus::kBadFrame) {
      std::fprintf(stderr, "tac3d: warning: %s (skipped)\n", tracker.last_error().c_str());
      continue;
    }
    if (a.json) {
      WriteLineFlushed(stdout, ToJson(frame, reference, tracker.cols()).dump());
    } else {
      AppendCsv(frame, reference, tracker.cols(), csv);
    }
    if (!a.overlay.empty()) {
      WriteImageFile(fmt::format("{}/frame_{:05d}.png", a.overlay, frame.index),
                     DrawDisplacementImage(frame.image, frame.markers, reference));
    }
  }
  const SingleViewTrackSummary summary = tracker.summary();
  if (a.json) {
    WriteLineFlushed(stdout, nlohmann::json{{"summary", ToJson(summary)}}.dump());
    return;
  }
  if (a.out.empty()) {
    std::fputs(csv.c_str(), stdout);
    return;
  }
  WriteTextFileAtomically(a.out, csv);
  PrintSummary(summary, !options.rest_frames.empty());
  std::printf("wrote %s\n", a.out.c_str());
}

}  // namespace

void RegisterTrack(CLI::App& app) {
  auto args = std::make_shared<TrackArgs>();
  CLI::App* cmd = app.add_subcommand(
      "track", "track a single-view marker sensor's markers (GelSight-like) in a video, image folder or camera");
  cmd->add_option("--source", args->source, "video file, image folder, camera:N or /dev/videoN")->required();
  cmd->add_option("--grid", args->grid, "the marker grid ROWSxCOLS (default: found in the reference frame)");
  cmd->add_option("--reference", args->reference,
                  "the reference frame (grid found, reference positions; earlier frames are skipped)");
  auto* out = cmd->add_option("--out", args->out, "write the CSV frame,row,col,x0,y0,x,y,state here "
                                                  "(default: to standard output) and print a summary");
  cmd->add_flag("--json", args->json,
                "print a JSON line per frame as it is tracked (every marker), then one with the summary")
      ->excludes(out);
  cmd->add_option("--overlay", args->overlay,
                  "write each frame as PNG with the markers drawn (green ring tracked, red cross not, "
                  "yellow arrow the displacement) into this folder");
  cmd->add_option("--rest-frames", args->rest_frames,
                  "frames without contact as FIRST:LAST[,FIRST:LAST...]: the summary gives the position "
                  "jitter over them");
  cmd->callback([args] { Track(*args); });
}

}  // namespace tac3d::cli
