#include "tac3d/tracking/single_view_track.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>

#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/json_number.h"

namespace tac3d {

std::string_view ToString(TrackedMarkerState state) {
  switch (state) {
    case TrackedMarkerState::kTracked: return "tracked";
    case TrackedMarkerState::kCut: return "cut";
    case TrackedMarkerState::kEstimated: return "estimated";
    case TrackedMarkerState::kLost: return "lost";
  }
  return "?";
}

TrackedMarkerState TrackedStateOf(const GridObservation& o, int i) {
  if (o.valid(i)) return TrackedMarkerState::kTracked;
  if (o.state[i] == MarkerState::kPartlyOutside) return TrackedMarkerState::kCut;
  return o.supported[i] ? TrackedMarkerState::kEstimated : TrackedMarkerState::kLost;
}

void SingleViewTrackOptions::Validate() const {
  tracker.Validate();
  const OptionCheck require("single-view track options");
  require(rows >= 0 && rows <= kMaxMarkerGridSide, "rows", "in [0, kMaxMarkerGridSide]", rows);
  require(cols >= 0 && cols <= kMaxMarkerGridSide, "cols", "in [0, kMaxMarkerGridSide]", cols);
  require((rows == 0) == (cols == 0), "rows", "0 with cols 0 (the grid found), else both given", rows);
  require(reference_frame >= 0, "reference_frame", ">= 0", static_cast<double>(reference_frame));
  for (const FrameRange& r : rest_frames) {
    require(r.first >= 0 && r.first <= r.last, "rest_frames", "ranges with 0 <= first <= last",
            static_cast<double>(r.first));
  }
}

nlohmann::json ToJson(const SingleViewTrackSummary& s) {
  return {{"source", s.source},
          {"reference", s.reference_frame},
          {"rows", s.rows},
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
          {"max_cut", s.max_cut},
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

nlohmann::json ToJson(const SingleViewTrackFrame& frame, const GridObservation& reference, int cols) {
  const GridObservation& o = frame.markers;
  const int n = static_cast<int>(o.state.size());
  TAC3D_DEMAND(cols > 0 && n % cols == 0 && reference.estimate_uv.size() == o.state.size());
  std::array<int, 4> counts{};
  nlohmann::json markers = nlohmann::json::array();
  for (int i = 0; i < n; ++i) {
    const TrackedMarkerState state = TrackedStateOf(o, i);
    ++counts[static_cast<int>(state)];
    const bool placed = state != TrackedMarkerState::kLost;
    markers.push_back({{"row", i / cols},
                       {"col", i % cols},
                       {"x0", reference.estimate_uv[i].x()},
                       {"y0", reference.estimate_uv[i].y()},
                       {"x", placed ? FiniteOrNull(o.estimate_uv[i].x()) : nlohmann::json()},
                       {"y", placed ? FiniteOrNull(o.estimate_uv[i].y()) : nlohmann::json()},
                       {"state", ToString(state)}});
  }
  return {{"frame", frame.index},
          {"timestamp_s", frame.timestamp_s},
          {"acquired", o.acquired},
          {"tracked", counts[0]},
          {"cut", counts[1]},
          {"estimated", counts[2]},
          {"lost", counts[3]},
          {"markers", std::move(markers)}};
}

std::unique_ptr<FrameSource> OpenSingleViewSource(const std::string& uri, const CameraSourceOptions& camera) {
  // A folder's images may be of any size (OpenFrameSource bounds them by a camera's).
  std::error_code ec;
  return std::filesystem::is_directory(uri, ec) ? OpenImageFolder(uri, camera.fps) : OpenFrameSource(uri, camera);
}

// Each marker's positions summed over each range of rest frames.
struct SingleViewSourceTracker::Jitter {
  int n = 0;
  std::vector<Eigen::Vector2d> sum, sum2;  // per range and marker: range * n + marker
  std::vector<int> count;

  Jitter(int ranges, int markers)
      : n(markers), sum(ranges * markers, Eigen::Vector2d::Zero()), sum2(sum), count(sum.size(), 0) {}
  void Add(int range, int i, const Eigen::Vector2d& p) {
    sum[range * n + i] += p;
    sum2[range * n + i] += p.cwiseProduct(p);
    ++count[range * n + i];
  }
  void Finish(SingleViewTrackSummary& s) const {
    Eigen::Vector2d squares = Eigen::Vector2d::Zero();
    int samples = 0;
    s.jitter_max_px = 0;
    for (size_t j = 0; j < sum.size(); ++j) {
      if (count[j] < 2) continue;
      const Eigen::Vector2d mean = sum[j] / count[j];
      const Eigen::Vector2d spread = (sum2[j] - count[j] * mean.cwiseProduct(mean)).cwiseMax(0.0);
      squares += spread;
      samples += count[j];
      s.jitter_max_px = std::max(s.jitter_max_px, std::sqrt(spread.maxCoeff() / count[j]));
    }
    s.jitter_x_px = samples > 0 ? std::sqrt(squares.x() / samples) : 0.0;
    s.jitter_y_px = samples > 0 ? std::sqrt(squares.y() / samples) : 0.0;
  }
};

SingleViewSourceTracker::SingleViewSourceTracker(std::unique_ptr<FrameSource> source,
                                                 const SingleViewTrackOptions& options)
    : source_(std::move(source)), options_(options) {
  TAC3D_DEMAND(source_ != nullptr);
  options_.Validate();
  std::int64_t read = 0;
  while (true) {
    const ReadStatus status = source_->Read(pending_);
    if (status == ReadStatus::kBadFrame) {
      ++summary_.bad_frames;
      continue;
    }
    if (status == ReadStatus::kFailed) throw Error(source_->last_error());
    if (status == ReadStatus::kEnd) {
      throw Error(fmt::format("{} ended after {} readable frames, before the reference frame {}{}",
                              source_->Describe(), read, options_.reference_frame,
                              read == 0 ? " (not a video, or no frame decodes)" : ""));
    }
    if (pending_.index >= options_.reference_frame) break;
    ++read;
  }
  tracker_.emplace(pending_.image, options_.rows, options_.cols, options_.tracker);
  const int n = rows() * cols();
  SingleViewTrackSummary& s = summary_;
  s.source = source_->Describe();
  s.reference_frame = options_.reference_frame;
  s.rows = rows();
  s.cols = cols();
  std::vector<double> pitches(n);
  for (int i = 0; i < n; ++i) pitches[i] = tracker_->pitch_px(i);
  std::nth_element(pitches.begin(), pitches.begin() + n / 2, pitches.end());
  s.pitch_px = pitches[n / 2];
  s.reference_tracked = reference().valid_markers;
  s.dot_radius_px = tracker_->grid().dot_radius_px;
  size_ = pending_.image.size();
  last_.assign(n, Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
  jitter_ = std::make_unique<Jitter>(static_cast<int>(options_.rest_frames.size()), n);
}

SingleViewSourceTracker::~SingleViewSourceTracker() = default;

ReadStatus SingleViewSourceTracker::Next(SingleViewTrackFrame& frame) {
  if (!reference_given_) {
    reference_given_ = true;
    frame.index = pending_.index;
    frame.timestamp_s = pending_.timestamp_s;
    frame.image = pending_.image;
    frame.markers = reference();
    pending_ = Frame();
    Account(frame);
    return ReadStatus::kOk;
  }
  Frame read;
  read.image = frame.image;  // its buffer reused when the frame fits
  const ReadStatus status = source_->Read(read);
  if (status == ReadStatus::kFailed) throw Error(source_->last_error());
  if (status == ReadStatus::kBadFrame) ++summary_.bad_frames;
  if (status != ReadStatus::kOk) return status;
  frame.index = read.index;
  frame.timestamp_s = read.timestamp_s;
  frame.image = read.image;
  tracker_->Track(frame.image, frame.markers);
  summary_.reacquisitions += frame.markers.acquired;
  Account(frame);
  return ReadStatus::kOk;
}

void SingleViewSourceTracker::Account(const SingleViewTrackFrame& frame) {
  SingleViewTrackSummary& s = summary_;
  const GridObservation& o = frame.markers;
  const GridObservation& ref = reference();
  const std::vector<FrameRange>& rest = options_.rest_frames;
  const auto range = std::find_if(rest.begin(), rest.end(), [&](const FrameRange& r) {
    return frame.index >= r.first && frame.index <= r.last;
  });
  s.rest_frames += range != rest.end();
  ++s.frames;
  const double margin = s.dot_radius_px + 2;
  auto away_from_border = [&](const Eigen::Vector2d& p) {
    return p.x() > margin - 0.5 && p.y() > margin - 0.5 && p.x() < size_.width - 0.5 - margin &&
           p.y() < size_.height - 0.5 - margin;
  };
  int lost = 0, estimated = 0, cut = 0, displaced = 0;
  double sum_px = 0, max_px = 0;
  for (int i = 0; i < rows() * cols(); ++i) {
    const TrackedMarkerState state = TrackedStateOf(o, i);
    lost += state == TrackedMarkerState::kLost;
    estimated += state == TrackedMarkerState::kEstimated;
    cut += state == TrackedMarkerState::kCut;
    if (o.state[i] != MarkerState::kPartlyOutside && away_from_border(o.estimate_uv[i])) {
      ++s.inside;
      s.inside_untracked += state != TrackedMarkerState::kTracked;
    }
    if (state != TrackedMarkerState::kTracked) continue;
    const Eigen::Vector2d& p = o.uv[i];
    if (last_[i].allFinite()) {
      const double step = (p - last_[i]).norm();
      s.max_step_px = std::max(s.max_step_px, step);
      s.swaps += step > 0.5 * tracker_->pitch_px(i);
    }
    last_[i] = p;
    if (ref.valid(i)) {
      const double d = (p - ref.uv[i]).norm();
      sum_px += d;
      max_px = std::max(max_px, d);
      ++displaced;
    }
    if (range != rest.end()) jitter_->Add(static_cast<int>(range - rest.begin()), i, p);
  }
  s.max_lost = std::max(s.max_lost, lost);
  s.max_estimated = std::max(s.max_estimated, estimated);
  s.max_cut = std::max(s.max_cut, cut);
  if (s.deepest_frame < 0 || max_px > s.deepest_max_px) {
    s.deepest_frame = frame.index;
    s.deepest_mean_px = displaced > 0 ? sum_px / displaced : 0;
    s.deepest_max_px = max_px;
  }
}

SingleViewTrackSummary SingleViewSourceTracker::summary() const {
  SingleViewTrackSummary s = summary_;
  jitter_->Finish(s);
  return s;
}

}  // namespace tac3d
