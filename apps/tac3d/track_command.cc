// `tac3d track`: a single-view marker sensor's markers tracked through a video, an image
// folder or a camera (docs/real-images.md).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/imagefile/image_write.h"
#include "tac3d/source/frame_source.h"
#include "tac3d/tracking/single_view_tracker.h"
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

// A marker's state as the CSV writes it.
enum class TrackState { kTracked, kEstimated, kLost };
const char* Name(TrackState s) {
  switch (s) {
    case TrackState::kTracked: return "tracked";
    case TrackState::kEstimated: return "estimated";
    case TrackState::kLost: return "lost";
  }
  return "?";
}

// Measured in the frame; else predicted from grid neighbours measured in it; else lost.
TrackState StateOf(const GridObservation& o, int i) {
  if (o.valid(i)) return TrackState::kTracked;
  return o.supported[i] ? TrackState::kEstimated : TrackState::kLost;
}

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
std::vector<std::pair<std::int64_t, std::int64_t>> ParseRanges(const std::string& text) {
  std::vector<std::pair<std::int64_t, std::int64_t>> ranges;
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
    ranges.emplace_back(std::stoll(m[1]), std::stoll(m[2]));
  }
  return ranges;
}

// What the run measured, over the frames from the reference on.
struct TrackSummary {
  int rows = 0, cols = 0;
  double pitch_px = 0;             // median over the markers
  int reference_tracked = 0;       // markers measured in the reference frame
  double dot_radius_px = 0;
  std::int64_t frames = 0;         // tracked, the reference's included
  std::int64_t bad_frames = 0;     // unreadable, skipped
  // Marker-frames of markers away from the border (not kPartlyOutside, and farther than the
  // dots' radius + 2 px from the image's edge), and those of them not tracked.
  std::int64_t inside = 0, inside_untracked = 0;
  int max_lost = 0;                // per frame
  int max_estimated = 0;           // per frame
  int reacquisitions = 0;          // frames where the grid was indexed afresh after the reference
  double max_step_px = 0;          // largest move of a tracked marker between tracked frames
  int swaps = 0;                   // moves of more than half the pitch
  std::int64_t deepest_frame = -1; // the largest displacement of a marker from the reference
  double deepest_mean_px = 0, deepest_max_px = 0;
  int rest_frames = 0;             // frames of --rest-frames tracked
  // RMS about each marker's mean over each range of rest frames, over all markers and ranges.
  double jitter_x_px = 0, jitter_y_px = 0;
  double jitter_max_px = 0;        // the worst marker's RMS in a range (per axis)
};

// Accumulates each marker's positions over each range of rest frames (the gel may settle
// elsewhere after a press, so each range has its own mean).
struct Jitter {
  int n;
  std::vector<Eigen::Vector2d> sum, sum2;  // per range and marker: range * n + marker
  std::vector<int> count;
  Jitter(int ranges, int markers)
      : n(markers), sum(ranges * markers, Eigen::Vector2d::Zero()), sum2(sum), count(sum.size(), 0) {}
  void Add(int range, int i, const Eigen::Vector2d& p) {
    sum[range * n + i] += p;
    sum2[range * n + i] += p.cwiseProduct(p);
    ++count[range * n + i];
  }
  void Finish(TrackSummary& s) const {
    Eigen::Vector2d squares = Eigen::Vector2d::Zero();
    int samples = 0;
    for (size_t j = 0; j < sum.size(); ++j) {
      if (count[j] < 2) continue;
      const Eigen::Vector2d mean = sum[j] / count[j];
      const Eigen::Vector2d spread = (sum2[j] - count[j] * mean.cwiseProduct(mean)).cwiseMax(0.0);
      squares += spread;
      samples += count[j];
      s.jitter_max_px = std::max(s.jitter_max_px, std::sqrt(spread.maxCoeff() / count[j]));
    }
    if (samples == 0) return;
    s.jitter_x_px = std::sqrt(squares.x() / samples);
    s.jitter_y_px = std::sqrt(squares.y() / samples);
  }
};

nlohmann::json ToJson(const TrackSummary& s) {
  return {{"rows", s.rows},
          {"cols", s.cols},
          {"pitch_px", s.pitch_px},
          {"reference_tracked", s.reference_tracked},
          {"frames", s.frames},
          {"bad_frames", s.bad_frames},
          {"dot_radius_px", s.dot_radius_px},
          {"inside", s.inside},
          {"inside_untracked", s.inside_untracked},
          {"max_lost", s.max_lost},
          {"max_estimated", s.max_estimated},
          {"reacquisitions", s.reacquisitions},
          {"max_step_px", s.max_step_px},
          {"swaps", s.swaps},
          {"deepest_frame", s.deepest_frame},
          {"deepest_mean_px", s.deepest_mean_px},
          {"deepest_max_px", s.deepest_max_px},
          {"rest_frames", s.rest_frames},
          {"jitter_x_px", s.jitter_x_px},
          {"jitter_y_px", s.jitter_y_px},
          {"jitter_max_px", s.jitter_max_px}};
}

// The viewer's picture of the frame (green rings tracked, red crosses not) with each tracked
// marker's displacement from its reference position as a yellow arrow.
void WriteOverlay(const std::string& dir, std::int64_t index, const cv::Mat& image, const GridObservation& o,
                  const GridObservation& reference, std::vector<ImageMarker>& markers) {
  markers.clear();
  AppendImageMarkers(o, markers);
  cv::Mat picture = DrawCameraImage(image, markers, image.cols);
  if (picture.channels() == 1) cv::cvtColor(picture, picture, cv::COLOR_GRAY2BGR);
  constexpr int kShift = 4;  // fixed-point fraction bits, as DrawCameraImage
  auto fixed = [](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround(p.x() * (1 << kShift))),
                     static_cast<int>(std::lround(p.y() * (1 << kShift))));
  };
  for (size_t i = 0; i < o.state.size(); ++i) {
    const Eigen::Vector2d& from = reference.estimate_uv[i];
    if (!o.valid(static_cast<int>(i)) || (o.uv[i] - from).norm() < 0.5) continue;
    cv::arrowedLine(picture, fixed(from), fixed(o.uv[i]), cv::Scalar(0, 230, 255), 1, cv::LINE_AA, kShift, 0.3);
  }
  const std::string path = fmt::format("{}/frame_{:05d}.png", dir, index);
  WriteImageFile(path, picture);
}

void Track(const TrackArgs& a) {
  if (a.source.empty()) throw Error("track: --source is required");
  if (a.reference < 0) throw Error(fmt::format("track: --reference {} must be >= 0", a.reference));
  const auto [rows, cols] = a.grid.empty() ? std::pair{0, 0} : ParseGrid(a.grid);
  const auto rest = ParseRanges(a.rest_frames);
  if (!a.out.empty()) CheckOutputFile(a.out, "--out", {}, {a.source});
  if (!a.overlay.empty()) MakeDirectory(a.overlay);
  // A folder's images may be of any size (OpenFrameSource bounds them by a camera's).
  std::error_code ec;
  std::unique_ptr<FrameSource> source =
      std::filesystem::is_directory(a.source, ec) ? OpenImageFolder(a.source) : OpenFrameSource(a.source);

  // Frames before the reference are read and skipped.
  Frame frame;
  TrackSummary s;
  auto next = [&]() -> bool {
    while (true) {
      switch (source->Read(frame)) {
        case ReadStatus::kOk: return true;
        case ReadStatus::kEnd: return false;
        case ReadStatus::kBadFrame:
          ++s.bad_frames;
          std::fprintf(stderr, "tac3d: warning: %s (skipped)\n", source->last_error().c_str());
          continue;
        case ReadStatus::kFailed: throw Error(fmt::format("track: {}", source->last_error()));
      }
    }
  };
  std::int64_t read = 0;
  bool have = false;
  while ((have = next()) && frame.index < a.reference) ++read;
  if (!have) {
    throw Error(fmt::format("track: {} ended after {} readable frames, before the reference frame {}{}",
                            source->Describe(), read, a.reference,
                            read == 0 ? " (not a video, or no frame decodes)" : ""));
  }
  SingleViewTracker tracker(frame.image, rows, cols);
  const GridObservation& reference = tracker.reference();
  const int n = tracker.grid().rows * tracker.grid().cols;
  s.rows = tracker.grid().rows;
  s.cols = tracker.grid().cols;
  std::vector<double> pitches(n);
  for (int i = 0; i < n; ++i) pitches[i] = tracker.pitch_px(i);
  std::nth_element(pitches.begin(), pitches.begin() + n / 2, pitches.end());
  s.pitch_px = pitches[n / 2];
  s.reference_tracked = reference.valid_markers;
  s.dot_radius_px = tracker.grid().dot_radius_px;
  const double margin = s.dot_radius_px + 2;
  const cv::Size size = frame.image.size();
  auto away_from_border = [&](const Eigen::Vector2d& p) {
    return p.x() > margin - 0.5 && p.y() > margin - 0.5 && p.x() < size.width - 0.5 - margin &&
           p.y() < size.height - 0.5 - margin;
  };

  std::string csv = "frame,row,col,x0,y0,x,y,state\n";
  nlohmann::json rows_json = nlohmann::json::array();
  auto number = [](double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : std::string(); };
  std::vector<ImageMarker> markers;
  std::vector<Eigen::Vector2d> last(n, Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
  Jitter jitter(static_cast<int>(rest.size()), n);
  GridObservation o;
  for (bool first = true; first || next(); first = false) {
    if (first) {
      o = reference;
    } else {
      tracker.Track(frame.image, o);
      s.reacquisitions += o.acquired;
    }
    ++s.frames;
    const auto range = std::find_if(rest.begin(), rest.end(),
                                    [&](const auto& r) { return frame.index >= r.first && frame.index <= r.second; });
    const bool at_rest = range != rest.end();
    s.rest_frames += at_rest;
    int lost = 0, estimated = 0, displaced = 0;
    double sum_px = 0, max_px = 0;
    for (int i = 0; i < n; ++i) {
      const TrackState state = StateOf(o, i);
      const Eigen::Vector2d& p0 = reference.estimate_uv[i];
      const Eigen::Vector2d p = state == TrackState::kLost ? Eigen::Vector2d::Constant(std::nan(""))
                                                             : o.estimate_uv[i];
      lost += state == TrackState::kLost;
      estimated += state == TrackState::kEstimated;
      if (o.state[i] != MarkerState::kPartlyOutside && away_from_border(o.estimate_uv[i])) {
        ++s.inside;
        s.inside_untracked += state != TrackState::kTracked;
      }
      if (state == TrackState::kTracked) {
        if (last[i].allFinite()) {
          const double step = (p - last[i]).norm();
          s.max_step_px = std::max(s.max_step_px, step);
          s.swaps += step > 0.5 * tracker.pitch_px(i);
        }
        last[i] = p;
        if (reference.valid(i)) {
          sum_px += (p - p0).norm();
          max_px = std::max(max_px, (p - p0).norm());
          ++displaced;
        }
        if (at_rest) jitter.Add(static_cast<int>(range - rest.begin()), i, p);
      }
      const int r = i / s.cols, c = i % s.cols;
      if (a.json) {
        rows_json.push_back({{"frame", frame.index}, {"row", r}, {"col", c}, {"x0", p0.x()}, {"y0", p0.y()},
                             {"x", std::isfinite(p.x()) ? nlohmann::json(p.x()) : nlohmann::json()},
                             {"y", std::isfinite(p.y()) ? nlohmann::json(p.y()) : nlohmann::json()},
                             {"state", Name(state)}});
      } else {
        csv += fmt::format("{},{},{},{},{},{},{},{}\n", frame.index, r, c, number(p0.x()), number(p0.y()),
                           number(p.x()), number(p.y()), Name(state));
      }
    }
    s.max_lost = std::max(s.max_lost, lost);
    s.max_estimated = std::max(s.max_estimated, estimated);
    const double mean_px = displaced > 0 ? sum_px / displaced : 0;
    if (s.deepest_frame < 0 || max_px > s.deepest_max_px) {
      s.deepest_frame = frame.index;
      s.deepest_mean_px = mean_px;
      s.deepest_max_px = max_px;
    }
    if (!a.overlay.empty()) WriteOverlay(a.overlay, frame.index, frame.image, o, reference, markers);
  }
  jitter.Finish(s);

  if (a.json) {
    nlohmann::json report = {{"source", source->Describe()}, {"reference", a.reference}, {"summary", ToJson(s)},
                             {"markers", rows_json}};
    std::printf("%s\n", report.dump(2).c_str());
    return;
  }
  if (a.out.empty()) {
    std::fputs(csv.c_str(), stdout);
    return;
  }
  WriteTextFileAtomically(a.out, csv);
  std::printf("%s: grid %d x %d, pitch %.1f px, dots %.1f px in radius; reference frame %lld: %d markers "
              "tracked\n",
              source->Describe().c_str(), s.rows, s.cols, s.pitch_px, s.dot_radius_px,
              static_cast<long long>(a.reference), s.reference_tracked);
  std::printf("%lld frames (%lld unreadable skipped); markers away from the border: %lld marker-frames, %lld of "
              "them not tracked; per frame at most %d estimated, %d lost; %d re-acquisitions\n",
              static_cast<long long>(s.frames), static_cast<long long>(s.bad_frames),
              static_cast<long long>(s.inside), static_cast<long long>(s.inside_untracked), s.max_estimated,
              s.max_lost, s.reacquisitions);
  std::printf("largest move between frames %.2f px; moves over half the pitch (identity swaps) %d\n",
              s.max_step_px, s.swaps);
  std::printf("deepest press (the largest displacement) in frame %lld: largest %.2f px, mean %.2f px\n",
              static_cast<long long>(s.deepest_frame), s.deepest_max_px, s.deepest_mean_px);
  if (!rest.empty()) {
    std::printf("jitter over %d rest frames: %.3f px RMS in x, %.3f px in y (worst marker %.3f px)\n",
                s.rest_frames, s.jitter_x_px, s.jitter_y_px, s.jitter_max_px);
  }
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
  cmd->add_flag("--json", args->json, "print JSON: the summary and every marker of every frame")->excludes(out);
  cmd->add_option("--overlay", args->overlay,
                  "write each frame as PNG with the markers drawn (green ring tracked, red cross not, "
                  "yellow arrow the displacement) into this folder");
  cmd->add_option("--rest-frames", args->rest_frames,
                  "frames without contact as FIRST:LAST[,FIRST:LAST...]: the summary gives the position "
                  "jitter over them");
  cmd->callback([args] { Track(*args); });
}

}  // namespace tac3d::cli
