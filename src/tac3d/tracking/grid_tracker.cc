#include "tac3d/tracking/grid_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A marker is measured at most this many times a frame: once, then again each time a new
// grid neighbour is accepted (its prediction gets better), up to this bound.
constexpr int kMaxTries = 3;

// How far a marker may move between frames for CalcReadRegion's region to hold its next
// measurement, in pitches: as far as tracking follows.
constexpr double kReadRegionMotionPitch = 1.0;
// MeasureBlob's reads beyond its blob radius from where it puts the blob: the background ring
// (1.25 px out) and the rounding of pixel positions.
constexpr double kReadBeyondBlobPx = 3.0;

}  // namespace

void MarkerTrackerOptions::Validate() const {
  blob.Validate();
  index.Validate();
  const OptionCheck require("marker tracker options");
  require(search_radius > 0 && search_radius < 0.5, "search_radius", "in (0, 0.5) pitch",
          search_radius);
  require(gate > 0 && gate <= search_radius, "gate", "in (0, search_radius] pitch", gate);
  require(blob_radius > 0 && blob_radius < 1, "blob_radius", "in (0, 1) pitch", blob_radius);
  require(min_separation > 0 && min_separation < 1, "min_separation", "in (0, 1) pitch",
          min_separation);
  require(min_valid_fraction > 0 && min_valid_fraction <= 1, "min_valid_fraction", "in (0, 1]",
          min_valid_fraction);
}

std::string_view ToString(MarkerState state) {
  switch (state) {
    case MarkerState::kValid: return "valid";
    case MarkerState::kNotFound: return "not found";
    case MarkerState::kBadShape: return "bad shape";
    case MarkerState::kInconsistent: return "inconsistent";
    case MarkerState::kConflict: return "conflict";
    case MarkerState::kGridLost: return "grid lost";
    case MarkerState::kPartlyOutside: return "partly outside";
  }
  return "?";
}

std::vector<double> CalcGridPitchPx(int rows, int cols, const std::vector<Eigen::Vector2d>& nominal) {
  TAC3D_DEMAND(static_cast<int>(nominal.size()) == rows * cols);
  std::vector<double> pitch(nominal.size(), std::numeric_limits<double>::infinity());
  for (int i = 0; i < rows * cols; ++i) {
    const int r = i / cols, c = i % cols;
    if (c + 1 < cols) pitch[i] = std::min(pitch[i], (nominal[i + 1] - nominal[i]).norm());
    if (c > 0) pitch[i] = std::min(pitch[i], (nominal[i - 1] - nominal[i]).norm());
    if (r + 1 < rows) pitch[i] = std::min(pitch[i], (nominal[i + cols] - nominal[i]).norm());
    if (r > 0) pitch[i] = std::min(pitch[i], (nominal[i - cols] - nominal[i]).norm());
  }
  return pitch;
}

void CheckTrackerImage(const cv::Mat& image, int width, int height) {
  if (image.empty()) {
    throw Error("marker tracker: empty image (an unreadable or corrupt file, or no camera frame)");
  }
  if (image.type() != CV_8UC1) {
    throw Error(fmt::format("marker tracker: image of type {}, 8-bit single channel (CV_8UC1) expected",
                            cv::typeToString(image.type())));
  }
  if (image.cols != width || image.rows != height) {
    throw Error(fmt::format("marker tracker: image of {} x {} px, the camera's is {} x {}", image.cols,
                            image.rows, width, height));
  }
}

GridTracker::GridTracker(int rows, int cols, const cv::Rect& roi, std::vector<Eigen::Vector2d> nominal,
                         const MarkerTrackerOptions& options, const std::string& what)
    : rows_(rows), cols_(cols), roi_(roi), nominal_(std::move(nominal)), options_(options) {
  options_.Validate();
  if (rows < 1 || cols < 1 || rows * cols < 2) {
    throw Error(fmt::format("marker tracker: a grid of {} x {} markers in {} (at least 2 are needed)", rows,
                            cols, what));
  }
  const int n = rows * cols;
  if (static_cast<int>(nominal_.size()) != n) {
    throw Error(fmt::format("marker tracker: {} nominal markers for a {} x {} grid in {}", nominal_.size(),
                            rows, cols, what));
  }
  if (roi.empty()) throw Error(fmt::format("marker tracker: {} has no pixels", what));
  for (int i = 0; i < n; ++i) {
    if (!nominal_[i].allFinite()) {
      throw Error(fmt::format("marker tracker: marker {} (row {}, col {}) of {} has no nominal pixel", i,
                              i / cols, i % cols, what));
    }
  }
  neighbour_begin_.reserve(n + 1);
  for (int i = 0; i < n; ++i) {
    neighbour_begin_.push_back(static_cast<int>(neighbours_.size()));
    const int r = i / cols_, c = i % cols_;
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        const int rr = r + dr, cc = c + dc;
        if ((dr != 0 || dc != 0) && rr >= 0 && rr < rows_ && cc >= 0 && cc < cols_) {
          neighbours_.push_back(rr * cols_ + cc);
        }
      }
    }
  }
  neighbour_begin_.push_back(static_cast<int>(neighbours_.size()));
  pitch_ = CalcGridPitchPx(rows_, cols_, nominal_);
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(pitch_[i]) || pitch_[i] < 2.0) {
      throw Error(fmt::format("marker tracker: markers too close in {} ({} px at marker {})", what, pitch_[i], i));
    }
  }
  estimate_.assign(n, Eigen::Vector2d::Zero());
  supported_.assign(n, 0);
  base_.assign(n, Eigen::Vector2d::Zero());
  found_.assign(n, Eigen::Vector2d::Zero());
  levels_.assign(n, Eigen::Vector2d::Zero());
  state_.assign(n, MarkerState::kGridLost);
  accepted_.assign(n, 0);
  cut_.assign(n, 0);
  queued_.assign(n, 0);
  tries_.assign(n, 0);
  queue_.assign(kMaxTries * n, 0);
}

template <typename F>
void GridTracker::ForNeighbours(int i, F&& f) const {
  for (int k = neighbour_begin_[i]; k < neighbour_begin_[i + 1]; ++k) f(neighbours_[k]);
}

Eigen::Vector2d GridTracker::Predict(int i) const {
  Eigen::Vector2d surprise = Eigen::Vector2d::Zero();
  int support = 0;
  ForNeighbours(i, [&](int j) {
    if (!accepted_[j]) return;
    surprise += found_[j] - base_[j];
    ++support;
  });
  return support > 0 ? Eigen::Vector2d(base_[i] + surprise / support) : base_[i];
}

MarkerState GridTracker::JudgeCut(int i, const Blob& blob, std::uint8_t sides, const Eigen::Vector2d& prediction) {
  // Only the coordinate along the border is the dot's own; across it the centroid is pulled
  // inward, and a dot cut at a corner has none.
  const Eigen::Vector2d off = blob.center - prediction;
  const double gate = options_.gate * pitch_[i];
  if ((!(sides & kBorderColumns) && std::abs(off.x()) > gate) || (!(sides & kBorderRows) && std::abs(off.y()) > gate)) {
    return MarkerState::kInconsistent;
  }
  found_[i] = blob.center;
  cut_[i] = sides;
  return MarkerState::kPartlyOutside;
}

MarkerState GridTracker::Judge(int i, const Blob& blob, const Eigen::Vector2d& prediction) const {
  const double pitch = pitch_[i];
  const double gate = options_.gate * pitch;
  if ((blob.center - prediction).squaredNorm() > gate * gate) return MarkerState::kInconsistent;
  const double separation2 = std::pow(options_.min_separation * pitch, 2);
  bool conflict = false;
  ForNeighbours(i, [&](int j) {
    conflict |= accepted_[j] && (blob.center - found_[j]).squaredNorm() < separation2;
  });
  return conflict ? MarkerState::kConflict : MarkerState::kValid;
}

void GridTracker::Grow(const cv::Mat& image, int head, int tail) {
  const int n = rows_ * cols_;
  auto push = [&](int i) {
    TAC3D_DEMAND(tail < static_cast<int>(queue_.size()));
    queue_[tail++] = i;
    queued_[i] = 1;
  };
  while (true) {
    while (head < tail) {
      const int i = queue_[head++];
      queued_[i] = 0;
      if (accepted_[i]) continue;
      // The next marker's pixels come from memory while this one is measured (near its
      // last position: its prediction is not known yet).
      if (head < tail) {
        const int next = queue_[head];
        PrefetchDisk(image, frame_roi_, base_[next], (options_.search_radius + options_.blob_radius) * pitch_[next]);
      }
      const Eigen::Vector2d prediction = Predict(i);
      ++tries_[i];
      const double pitch = pitch_[i];
      Blob blob;
      const BlobStatus status = MeasureBlob(image, frame_roi_, prediction, options_.search_radius * pitch,
                                            options_.blob_radius * pitch, options_.blob, blob);
      if (status == BlobStatus::kNoBlob) {
        state_[i] = MarkerState::kNotFound;
        continue;
      }
      // A dot cut by the border fails the shape checks too, so the border is checked first.
      const std::uint8_t sides = BlobReachesBorder(image, frame_roi_, blob, options_.blob_radius * pitch);
      if (sides != 0) {
        state_[i] = JudgeCut(i, blob, sides, prediction);
        continue;
      }
      if (status == BlobStatus::kBadShape) {
        state_[i] = MarkerState::kBadShape;
        continue;
      }
      state_[i] = Judge(i, blob, prediction);
      if (state_[i] != MarkerState::kValid) continue;
      accepted_[i] = 1;
      found_[i] = blob.center;
      levels_[i] = {blob.background_dn, blob.contrast_dn};
      ForNeighbours(i, [&](int j) {
        if (!accepted_[j] && !queued_[j] && tries_[j] < kMaxTries) push(j);
      });
    }
    // Markers no accepted neighbour reached (their whole surround lost): try each alone.
    bool pushed = false;
    for (int i = 0; i < n; ++i) {
      if (tries_[i] == 0 && !queued_[i]) {
        push(i);
        pushed = true;
      }
    }
    if (!pushed) break;
  }
}

int GridTracker::CountValid() const {
  return static_cast<int>(std::count(accepted_.begin(), accepted_.end(), 1));
}

void GridTracker::Commit() {
  for (int i = 0; i < rows_ * cols_; ++i) {
    supported_[i] = accepted_[i];
    if (accepted_[i]) {
      estimate_[i] = found_[i];
      continue;
    }
    // Not measured: where its measured neighbours' displacements from the nominal grid put
    // it. Not from its own last estimate, whose error would be carried on frame after frame
    // (and, once past the gate, keep the marker from ever being found again).
    Eigen::Vector2d displacement = Eigen::Vector2d::Zero();
    int support = 0;
    ForNeighbours(i, [&](int j) {
      if (!accepted_[j]) return;
      displacement += found_[j] - nominal_[j];
      ++support;
    });
    // With no measured neighbour it stays where it was looked for.
    estimate_[i] = support > 0 ? Eigen::Vector2d(nominal_[i] + displacement / support) : base_[i];
    supported_[i] = support > 0;
    if (state_[i] != MarkerState::kPartlyOutside) continue;
    // A dot cut by the border: along the border, where its own blob is.
    if (!(cut_[i] & kBorderColumns)) estimate_[i].x() = found_[i].x();
    if (!(cut_[i] & kBorderRows)) estimate_[i].y() = found_[i].y();
    supported_[i] = 1;
  }
}

void GridTracker::TrackGrid(const cv::Mat& image) {
  const int n = rows_ * cols_;
  for (int i = 0; i < n; ++i) {
    base_[i] = estimate_[i];
    accepted_[i] = queued_[i] = tries_[i] = cut_[i] = 0;
    state_[i] = MarkerState::kNotFound;
  }
  // Seeds: the outer ring, walked around so each seed after the first has a neighbour.
  int tail = 0;
  auto push = [&](int i) {
    queue_[tail++] = i;
    queued_[i] = 1;
  };
  for (int c = 0; c < cols_; ++c) push(c);
  for (int r = 1; r < rows_; ++r) push(r * cols_ + cols_ - 1);
  for (int c = cols_ - 2; c >= 0 && rows_ > 1; --c) push((rows_ - 1) * cols_ + c);
  for (int r = rows_ - 2; r >= 1 && cols_ > 1; --r) push(r * cols_);
  Grow(image, 0, tail);
  Commit();
  tracking_ = CountValid() >= options_.min_valid_fraction * n && !GridJumped(image);
}

bool GridTracker::GridJumped(const cv::Mat& image) const {
  if (rows_ < 2 || cols_ < 2) return false;
  // A side of the ring: its markers from `first` on by `step`, and the step to the next ring in.
  struct Side {
    int first, step, count, inward;
  };
  const std::array<Side, 4> sides = {{{0, 1, cols_, cols_},  // top, bottom, left, right
                                      {(rows_ - 1) * cols_, 1, cols_, -cols_},
                                      {0, cols_, rows_, 1},
                                      {cols_ - 1, cols_, rows_, -1}}};
  for (int s = 0; s < 4; ++s) {
    const Side& trailing = sides[s];
    int valid = 0, outside = 0;
    for (int k = 0; k < trailing.count; ++k) {
      const int i = trailing.first + k * trailing.step;
      valid += accepted_[i];
      outside += state_[i] == MarkerState::kPartlyOutside;
    }
    // A side cut by the image's border is not lost: it is where it was.
    if (2 * (valid + outside) >= trailing.count) continue;
    // The grid moved away from this side (or it is hidden): a jump puts dots a pitch beyond
    // the opposite side, where the film is blank.
    const Side& leading = sides[s ^ 1];
    int dots = 0;
    for (int k = 0; k < leading.count; ++k) {
      const int i = leading.first + k * leading.step, j = i + leading.inward;
      if (!accepted_[i] || !accepted_[j]) continue;
      const Eigen::Vector2d beyond = 2 * found_[i] - found_[j];
      const double pitch = pitch_[i];
      Blob blob;
      const double gate = options_.gate * pitch;
      dots += MeasureBlob(image, frame_roi_, beyond, options_.search_radius * pitch, options_.blob_radius * pitch,
                          options_.blob, blob) == BlobStatus::kFound &&
              (blob.center - beyond).squaredNorm() <= gate * gate;
    }
    if (2 * dots > leading.count) return true;
  }
  return false;
}

void GridTracker::KeepLargestConsistentSeeds() {
  const int n = rows_ * cols_;
  // Label the seeds' components: neighbours join when their deviations from the affine
  // map differ by less than the gate (a smooth field, not a seam or a pulled centroid).
  std::vector<int> label(n, -1);
  int best_label = -1, best_size = 0;
  for (int start = 0, next_label = 0; start < n; ++start) {
    if (!accepted_[start] || label[start] >= 0) continue;
    int head = 0, tail = 0, size = 0;
    queue_[tail++] = start;
    label[start] = next_label;
    while (head < tail) {
      const int i = queue_[head++];
      ++size;
      const Eigen::Vector2d deviation = found_[i] - base_[i];
      const double limit = options_.gate * pitch_[i];
      ForNeighbours(i, [&](int j) {
        if (!accepted_[j] || label[j] >= 0) return;
        if ((found_[j] - base_[j] - deviation).squaredNorm() > limit * limit) return;
        label[j] = next_label;
        queue_[tail++] = j;
      });
    }
    if (size > best_size) {
      best_size = size;
      best_label = next_label;
    }
    ++next_label;
  }
  for (int i = 0; i < n; ++i) {
    if (!accepted_[i] || label[i] == best_label) continue;
    accepted_[i] = 0;
    tries_[i] = 0;
    state_[i] = MarkerState::kNotFound;
  }
}

void GridTracker::Acquire(const cv::Mat& image) {
  const int n = rows_ * cols_;
  const std::vector<Blob> blobs = DetectBlobs(image, roi_, options_.blob);
  std::vector<Eigen::Vector2d> centers(blobs.size());
  for (size_t j = 0; j < blobs.size(); ++j) centers[j] = blobs[j].center;
  // Each candidate indexing seeds the grid with its matched markers (the largest part that
  // agrees with itself: under a strong dent or shear some displaced markers match their
  // neighbours' places, a seam against the rest); the affine map
  // predicts the others, corrected by their neighbours' deviation from it (a dent or shear
  // the map cannot follow). The candidate that ends with the most valid markers wins: one
  // a pitch off loses a row or column of markers over the grid's border.
  int best_valid = -1;
  std::vector<Eigen::Vector2d> best_base, best_found, best_levels;
  std::vector<MarkerState> best_state;
  std::vector<std::uint8_t> best_accepted, best_cut;
  for (const GridIndex& index : IndexGrid(centers, nominal_, pitch_, options_.index)) {
    std::fill(state_.begin(), state_.end(), MarkerState::kNotFound);
    std::fill(accepted_.begin(), accepted_.end(), 0);
    std::fill(queued_.begin(), queued_.end(), 0);
    std::fill(tries_.begin(), tries_.end(), 0);
    std::fill(cut_.begin(), cut_.end(), 0);
    for (int i = 0; i < n; ++i) {
      base_[i] = index.Map(nominal_[i]);
      const int j = index.detection_of_marker[i];
      if (j < 0) continue;
      tries_[i] = 1;
      if (const std::uint8_t sides = BlobReachesBorder(image, roi_, blobs[j], options_.blob_radius * pitch_[i])) {
        state_[i] = JudgeCut(i, blobs[j], sides, base_[i]);
        continue;
      }
      accepted_[i] = 1;
      found_[i] = centers[j];
      levels_[i] = {blobs[j].background_dn, blobs[j].contrast_dn};
      state_[i] = MarkerState::kValid;
    }
    KeepLargestConsistentSeeds();
    int tail = 0;
    for (int i = 0; i < n; ++i) {
      if (!accepted_[i]) continue;
      ForNeighbours(i, [&](int j) {
        if (accepted_[j] || queued_[j]) return;
        queue_[tail++] = j;
        queued_[j] = 1;
      });
    }
    Grow(image, 0, tail);
    const int valid = CountValid();
    if (valid <= best_valid) continue;
    best_valid = valid;
    best_base = base_;
    best_found = found_;
    best_levels = levels_;
    best_state = state_;
    best_accepted = accepted_;
    best_cut = cut_;
    if (valid == n) break;
  }
  tracking_ = false;
  if (best_valid < 0) {
    std::fill(state_.begin(), state_.end(), MarkerState::kNotFound);
    return;
  }
  base_ = std::move(best_base);
  found_ = std::move(best_found);
  levels_ = std::move(best_levels);
  state_ = std::move(best_state);
  accepted_ = std::move(best_accepted);
  cut_ = std::move(best_cut);
  Commit();
  tracking_ = best_valid >= options_.min_valid_fraction * n;
}

void GridTracker::Track(const cv::Mat& image, GridObservation& out, const std::optional<cv::Rect>& decoded) {
  TAC3D_DEMAND(image.type() == CV_8UC1 && (roi_ & cv::Rect(0, 0, image.cols, image.rows)) == roi_);
  const int n = rows_ * cols_;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  frame_roi_ = decoded ? roi_ & *decoded : roi_;
  out.acquired = false;
  if (tracking_) TrackGrid(image);
  // Acquisition searches the whole roi: of a partly decoded image, the grid is lost until a whole
  // one comes (CalcReadRegion asks for it).
  if (!tracking_ && frame_roi_ == roi_) {
    out.acquired = true;
    Acquire(image);
  }
  out.grid_lost = !tracking_;
  out.uv.resize(n);
  out.estimate_uv.resize(n);
  out.supported.resize(n);
  out.background_dn.resize(n);
  out.contrast_dn.resize(n);
  out.state.resize(n);
  out.state_counts.fill(0);
  for (int i = 0; i < n; ++i) {
    out.state[i] = out.grid_lost ? MarkerState::kGridLost : state_[i];
    const bool valid = out.state[i] == MarkerState::kValid;
    out.uv[i] = valid ? found_[i] : Eigen::Vector2d(nan, nan);
    out.estimate_uv[i] = out.grid_lost ? nominal_[i] : estimate_[i];
    out.supported[i] = !out.grid_lost && supported_[i];
    out.background_dn[i] = valid ? levels_[i].x() : nan;
    out.contrast_dn[i] = valid ? levels_[i].y() : nan;
    ++out.state_counts[static_cast<int>(out.state[i])];
  }
  out.valid_markers = out.state_counts[static_cast<int>(MarkerState::kValid)];
}

std::optional<cv::Rect> GridTracker::CalcReadRegion() const {
  if (!tracking_) return std::nullopt;
  // A marker is measured within its search radius of its prediction (its estimate moved by its
  // neighbours' motion), over its blob radius around the darkest pixel there, whose centroid
  // may lie a blob radius further.
  const double reach_pitch = options_.search_radius + 2 * options_.blob_radius + kReadRegionMotionPitch;
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  for (int i = 0; i < rows_ * cols_; ++i) {
    const double reach = reach_pitch * pitch_[i] + kReadBeyondBlobPx;
    x0 = std::min(x0, estimate_[i].x() - reach);
    y0 = std::min(y0, estimate_[i].y() - reach);
    x1 = std::max(x1, estimate_[i].x() + reach);
    y1 = std::max(y1, estimate_[i].y() + reach);
  }
  const int left = static_cast<int>(std::floor(x0)), top = static_cast<int>(std::floor(y0));
  const int right = static_cast<int>(std::ceil(x1)), bottom = static_cast<int>(std::ceil(y1));
  return cv::Rect(left, top, right - left + 1, bottom - top + 1) & roi_;
}

}  // namespace tac3d
