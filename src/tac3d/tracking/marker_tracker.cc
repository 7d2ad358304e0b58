#include "tac3d/tracking/marker_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

// A marker is measured at most this many times a frame: once, then again each time a new
// grid neighbour is accepted (its prediction gets better), up to this bound.
constexpr int kMaxTries = 3;

// Where a half's markers are looked for and where the undeformed sensor's are in it.
struct HalfSeed {
  cv::Rect roi;
  std::vector<Eigen::Vector2d> nominal;
};

// The mirror model's halves: each virtual camera's columns, the nominal markers projected
// through the mirrors, glass and silicone.
std::array<HalfSeed, 2> SeedMirrorHalves(const SensorConfig& config) {
  const OpticalLayout layout = config.MakeOpticalLayout(true);
  const std::vector<Eigen::Vector3d> markers = config.MarkerPositions();
  const int width = config.camera.intrinsics.width, height = config.camera.intrinsics.height;
  std::array<HalfSeed, 2> seeds;
  for (ImageHalf which : kImageHalves) {
    HalfSeed& seed = seeds[static_cast<int>(which)];
    const auto camera = std::find_if(config.virtual_cameras.begin(), config.virtual_cameras.end(),
                                     [&](const VirtualCameraConfig& v) { return v.half == which; });
    if (camera == config.virtual_cameras.end()) {
      throw Error(fmt::format("marker tracker: the sensor config has no virtual camera for the {} half",
                              ToString(which)));
    }
    seed.roi = cv::Rect(camera->column_begin, 0, camera->column_end - camera->column_begin, height) &
               cv::Rect(0, 0, width, height);
    if (seed.roi.empty()) {
      throw Error(fmt::format("marker tracker: {} has no columns in the {} x {} image", camera->name,
                              width, height));
    }
    for (size_t i = 0; i < markers.size(); ++i) {
      const auto uv = ProjectPoint(layout, which, markers[i]);
      if (!uv) {
        throw Error(fmt::format("marker tracker: marker {} (row {}, col {}) of the nominal sensor is "
                                "not seen in the {} half",
                                i, i / config.markers.cols, i % config.markers.cols, ToString(which)));
      }
      seed.nominal.push_back(*uv);
    }
  }
  return seeds;
}

// A vendor model's views (VendorCameraModelConfig::ViewColumns): the reference pixels, in the
// camera's image as delivered (the vendor's flip undone).
std::array<HalfSeed, 2> SeedVendorHalves(const SensorConfig& config) {
  const VendorCameraModelConfig& model = *config.vendor_camera;
  const int width = config.camera.intrinsics.width, height = config.camera.intrinsics.height;
  const std::array<std::pair<int, int>, 2> columns = model.ViewColumns(width, height);
  std::array<HalfSeed, 2> seeds;
  for (ImageHalf which : kImageHalves) {
    const int h = static_cast<int>(which);
    seeds[h].roi = cv::Rect(columns[h].first, 0, columns[h].second - columns[h].first, height);
    for (const Eigen::Vector2d& p : model.reference_pixels[h]) seeds[h].nominal.push_back(model.FlipPixel(p, width, height));
  }
  return seeds;
}

// Every nominal marker must lie in its half's columns.
std::array<HalfSeed, 2> SeedHalves(const SensorConfig& config) {
  std::array<HalfSeed, 2> seeds = config.vendor_camera ? SeedVendorHalves(config) : SeedMirrorHalves(config);
  for (ImageHalf which : kImageHalves) {
    const HalfSeed& seed = seeds[static_cast<int>(which)];
    for (size_t i = 0; i < seed.nominal.size(); ++i) {
      const Eigen::Vector2d& uv = seed.nominal[i];
      if (!seed.roi.contains(cv::Point(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y()))))) {
        throw Error(fmt::format("marker tracker: marker {} (row {}, col {}) of the nominal sensor is not seen in "
                                "the {} half",
                                i, i / config.markers.cols, i % config.markers.cols, ToString(which)));
      }
    }
  }
  return seeds;
}

// The blob options' pixel sizes for this sensor's image scale (MarkerTrackerOptions::blob).
BlobOptions ScaleBlobOptions(const BlobOptions& options, const std::vector<double>& left_pitch_px,
                             const std::vector<double>& right_pitch_px) {
  const double largest_pitch_px = std::max(*std::max_element(left_pitch_px.begin(), left_pitch_px.end()),
                                           *std::max_element(right_pitch_px.begin(), right_pitch_px.end()));
  const double scale = largest_pitch_px / kBlobOptionsPitchPx;
  if (scale <= 1.0) return options;
  BlobOptions scaled = options;
  scaled.min_spread_px *= scale;
  scaled.max_spread_px *= scale;
  scaled.background_kernel_px = 2 * static_cast<int>(std::lround(0.5 * (options.background_kernel_px - 1) * scale)) + 1;
  scaled.min_area_px = static_cast<int>(std::lround(options.min_area_px * scale * scale));
  scaled.max_area_px = static_cast<int>(std::lround(options.max_area_px * scale * scale));
  return scaled;
}

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
  }
  return "?";
}

MarkerTracker::MarkerTracker(const SensorConfig& config, const MarkerTrackerOptions& options)
    : config_(config), options_(options), rows_(config.markers.rows), cols_(config.markers.cols) {
  options_.Validate();
  const int n = rows_ * cols_;
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
  std::array<HalfSeed, 2> seeds = SeedHalves(config);
  for (ImageHalf which : kImageHalves) {
    Half& half = halves_[static_cast<int>(which)];
    half.roi = seeds[static_cast<int>(which)].roi;
    half.nominal = std::move(seeds[static_cast<int>(which)].nominal);
    half.pitch.assign(n, std::numeric_limits<double>::infinity());
    for (int i = 0; i < n; ++i) {
      const int r = i / cols_, c = i % cols_;
      if (c + 1 < cols_) half.pitch[i] = std::min(half.pitch[i], (half.nominal[i + 1] - half.nominal[i]).norm());
      if (c > 0) half.pitch[i] = std::min(half.pitch[i], (half.nominal[i - 1] - half.nominal[i]).norm());
      if (r + 1 < rows_) half.pitch[i] = std::min(half.pitch[i], (half.nominal[i + cols_] - half.nominal[i]).norm());
      if (r > 0) half.pitch[i] = std::min(half.pitch[i], (half.nominal[i - cols_] - half.nominal[i]).norm());
      if (!std::isfinite(half.pitch[i]) || half.pitch[i] < 2.0) {
        throw Error(fmt::format("marker tracker: markers too close in the {} half ({} px at marker {})",
                                ToString(which), half.pitch[i], i));
      }
    }
    half.estimate.assign(n, Eigen::Vector2d::Zero());
    half.base.assign(n, Eigen::Vector2d::Zero());
    half.found.assign(n, Eigen::Vector2d::Zero());
    half.levels.assign(n, Eigen::Vector2d::Zero());
    half.state.assign(n, MarkerState::kGridLost);
    half.accepted.assign(n, 0);
    half.queued.assign(n, 0);
    half.tries.assign(n, 0);
    half.queue.assign(kMaxTries * n, 0);
  }
  blob_ = ScaleBlobOptions(options_.blob, halves_[0].pitch, halves_[1].pitch);
}

template <typename F>
void MarkerTracker::ForNeighbours(int i, F&& f) const {
  for (int k = neighbour_begin_[i]; k < neighbour_begin_[i + 1]; ++k) f(neighbours_[k]);
}

void MarkerTracker::Reset() {
  for (Half& half : halves_) half.tracking = false;
}

Eigen::Vector2d MarkerTracker::Predict(const Half& half, int i) const {
  Eigen::Vector2d surprise = Eigen::Vector2d::Zero();
  int support = 0;
  ForNeighbours(i, [&](int j) {
    if (!half.accepted[j]) return;
    surprise += half.found[j] - half.base[j];
    ++support;
  });
  return support > 0 ? Eigen::Vector2d(half.base[i] + surprise / support) : half.base[i];
}

void MarkerTracker::Grow(const cv::Mat& image, Half& half, int head, int tail) const {
  const int n = rows_ * cols_;
  auto push = [&](int i) {
    TAC3D_DEMAND(tail < static_cast<int>(half.queue.size()));
    half.queue[tail++] = i;
    half.queued[i] = 1;
  };
  while (true) {
    while (head < tail) {
      const int i = half.queue[head++];
      half.queued[i] = 0;
      if (half.accepted[i]) continue;
      const Eigen::Vector2d prediction = Predict(half, i);
      ++half.tries[i];
      const double pitch = half.pitch[i];
      const double search = options_.search_radius * pitch;
      Blob blob;
      const BlobStatus status = MeasureBlob(image, half.roi, prediction, search,
                                            options_.blob_radius * pitch, blob_, blob);
      if (status != BlobStatus::kFound) {
        half.state[i] = status == BlobStatus::kNoBlob ? MarkerState::kNotFound : MarkerState::kBadShape;
        continue;
      }
      const double gate = options_.gate * pitch;
      if ((blob.center - prediction).squaredNorm() > gate * gate) {
        half.state[i] = MarkerState::kInconsistent;
        continue;
      }
      const double separation2 = std::pow(options_.min_separation * pitch, 2);
      bool conflict = false;
      ForNeighbours(i, [&](int j) {
        conflict |= half.accepted[j] && (blob.center - half.found[j]).squaredNorm() < separation2;
      });
      if (conflict) {
        half.state[i] = MarkerState::kConflict;
        continue;
      }
      half.state[i] = MarkerState::kValid;
      half.accepted[i] = 1;
      half.found[i] = blob.center;
      half.levels[i] = {blob.background_dn, blob.contrast_dn};
      ForNeighbours(i, [&](int j) {
        if (!half.accepted[j] && !half.queued[j] && half.tries[j] < kMaxTries) push(j);
      });
    }
    // Markers no accepted neighbour reached (their whole surround lost): try each alone.
    bool pushed = false;
    for (int i = 0; i < n; ++i) {
      if (half.tries[i] == 0 && !half.queued[i]) {
        push(i);
        pushed = true;
      }
    }
    if (!pushed) break;
  }
}

int MarkerTracker::CountValid(const Half& half) const {
  return static_cast<int>(std::count(half.accepted.begin(), half.accepted.end(), 1));
}

void MarkerTracker::Commit(Half& half) const {
  for (int i = 0; i < rows_ * cols_; ++i) {
    half.estimate[i] = half.accepted[i] ? half.found[i] : Predict(half, i);
  }
}

void MarkerTracker::TrackHalf(const cv::Mat& image, Half& half) const {
  const int n = rows_ * cols_;
  for (int i = 0; i < n; ++i) {
    half.base[i] = half.estimate[i];
    half.accepted[i] = half.queued[i] = half.tries[i] = 0;
    half.state[i] = MarkerState::kNotFound;
  }
  // Seeds: the outer ring, walked around so each seed after the first has a neighbour.
  int tail = 0;
  auto push = [&](int i) {
    half.queue[tail++] = i;
    half.queued[i] = 1;
  };
  for (int c = 0; c < cols_; ++c) push(c);
  for (int r = 1; r < rows_; ++r) push(r * cols_ + cols_ - 1);
  for (int c = cols_ - 2; c >= 0 && rows_ > 1; --c) push((rows_ - 1) * cols_ + c);
  for (int r = rows_ - 2; r >= 1 && cols_ > 1; --r) push(r * cols_);
  Grow(image, half, 0, tail);
  Commit(half);
  half.tracking = CountValid(half) >= options_.min_valid_fraction * n && !GridJumped(image, half);
}

bool MarkerTracker::GridJumped(const cv::Mat& image, const Half& half) const {
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
    int valid = 0;
    for (int k = 0; k < trailing.count; ++k) valid += half.accepted[trailing.first + k * trailing.step];
    if (2 * valid >= trailing.count) continue;
    // The grid moved away from this side (or it is hidden): a jump puts dots a pitch beyond
    // the opposite side, where the film is blank.
    const Side& leading = sides[s ^ 1];
    int dots = 0;
    for (int k = 0; k < leading.count; ++k) {
      const int i = leading.first + k * leading.step, j = i + leading.inward;
      if (!half.accepted[i] || !half.accepted[j]) continue;
      const Eigen::Vector2d beyond = 2 * half.found[i] - half.found[j];
      const double pitch = half.pitch[i];
      Blob blob;
      const double gate = options_.gate * pitch;
      dots += MeasureBlob(image, half.roi, beyond, options_.search_radius * pitch,
                          options_.blob_radius * pitch, blob_, blob) == BlobStatus::kFound &&
              (blob.center - beyond).squaredNorm() <= gate * gate;
    }
    if (2 * dots > leading.count) return true;
  }
  return false;
}

void MarkerTracker::KeepLargestConsistentSeeds(Half& half) const {
  const int n = rows_ * cols_;
  // Label the seeds' components: neighbours join when their deviations from the affine
  // map differ by less than the gate (a smooth field, not a seam or a pulled centroid).
  std::vector<int> label(n, -1);
  int best_label = -1, best_size = 0;
  for (int start = 0, next_label = 0; start < n; ++start) {
    if (!half.accepted[start] || label[start] >= 0) continue;
    int head = 0, tail = 0, size = 0;
    half.queue[tail++] = start;
    label[start] = next_label;
    while (head < tail) {
      const int i = half.queue[head++];
      ++size;
      const Eigen::Vector2d deviation = half.found[i] - half.base[i];
      const double limit = options_.gate * half.pitch[i];
      ForNeighbours(i, [&](int j) {
        if (!half.accepted[j] || label[j] >= 0) return;
        if ((half.found[j] - half.base[j] - deviation).squaredNorm() > limit * limit) return;
        label[j] = next_label;
        half.queue[tail++] = j;
      });
    }
    if (size > best_size) {
      best_size = size;
      best_label = next_label;
    }
    ++next_label;
  }
  for (int i = 0; i < n; ++i) {
    if (!half.accepted[i] || label[i] == best_label) continue;
    half.accepted[i] = 0;
    half.tries[i] = 0;
    half.state[i] = MarkerState::kNotFound;
  }
}

void MarkerTracker::AcquireHalf(const cv::Mat& image, Half& half) const {
  const int n = rows_ * cols_;
  const std::vector<Blob> blobs = DetectBlobs(image, half.roi, blob_);
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
  std::vector<std::uint8_t> best_accepted;
  for (const GridIndex& index : IndexGrid(centers, half.nominal, half.pitch, options_.index)) {
    std::fill(half.state.begin(), half.state.end(), MarkerState::kNotFound);
    std::fill(half.accepted.begin(), half.accepted.end(), 0);
    std::fill(half.queued.begin(), half.queued.end(), 0);
    std::fill(half.tries.begin(), half.tries.end(), 0);
    for (int i = 0; i < n; ++i) {
      half.base[i] = index.Map(half.nominal[i]);
      const int j = index.detection_of_marker[i];
      if (j < 0) continue;
      half.accepted[i] = 1;
      half.tries[i] = 1;
      half.found[i] = centers[j];
      half.levels[i] = {blobs[j].background_dn, blobs[j].contrast_dn};
      half.state[i] = MarkerState::kValid;
    }
    KeepLargestConsistentSeeds(half);
    int tail = 0;
    for (int i = 0; i < n; ++i) {
      if (!half.accepted[i]) continue;
      ForNeighbours(i, [&](int j) {
        if (half.accepted[j] || half.queued[j]) return;
        half.queue[tail++] = j;
        half.queued[j] = 1;
      });
    }
    Grow(image, half, 0, tail);
    const int valid = CountValid(half);
    if (valid <= best_valid) continue;
    best_valid = valid;
    best_base = half.base;
    best_found = half.found;
    best_levels = half.levels;
    best_state = half.state;
    best_accepted = half.accepted;
    if (valid == n) break;
  }
  half.tracking = false;
  if (best_valid < 0) {
    std::fill(half.state.begin(), half.state.end(), MarkerState::kNotFound);
    return;
  }
  half.base = std::move(best_base);
  half.found = std::move(best_found);
  half.levels = std::move(best_levels);
  half.state = std::move(best_state);
  half.accepted = std::move(best_accepted);
  Commit(half);
  half.tracking = best_valid >= options_.min_valid_fraction * n;
}

void MarkerTracker::Track(const cv::Mat& image, MarkerObservation& observation) {
  const auto start = std::chrono::steady_clock::now();
  const int width = config_.camera.intrinsics.width, height = config_.camera.intrinsics.height;
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
  const int n = rows_ * cols_;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  observation.rows = rows_;
  observation.cols = cols_;
  auto& summary = observation.summary;
  summary = {};
  summary.frame_index = frame_index_++;
  for (int h = 0; h < 2; ++h) {
    Half& half = halves_[h];
    HalfObservation& out = observation.halves[h];
    out.acquired = false;
    if (half.tracking) TrackHalf(image, half);
    if (!half.tracking) {
      out.acquired = true;
      AcquireHalf(image, half);
    }
    out.grid_lost = !half.tracking;
    out.uv.resize(n);
    out.estimate_uv.resize(n);
    out.background_dn.resize(n);
    out.contrast_dn.resize(n);
    out.state.resize(n);
    out.state_counts.fill(0);
    for (int i = 0; i < n; ++i) {
      out.state[i] = out.grid_lost ? MarkerState::kGridLost : half.state[i];
      const bool valid = out.state[i] == MarkerState::kValid;
      out.uv[i] = valid ? half.found[i] : Eigen::Vector2d(nan, nan);
      out.estimate_uv[i] = out.grid_lost ? half.nominal[i] : half.estimate[i];
      out.background_dn[i] = valid ? half.levels[i].x() : nan;
      out.contrast_dn[i] = valid ? half.levels[i].y() : nan;
      ++out.state_counts[static_cast<int>(out.state[i])];
    }
    out.valid_markers = out.state_counts[static_cast<int>(MarkerState::kValid)];
    summary.invalid_markers += n - out.valid_markers;
    summary.acquired |= out.acquired;
    summary.grid_lost |= out.grid_lost;
  }
  for (int i = 0; i < n; ++i) summary.paired_markers += observation.paired(i);
  summary.seconds = SecondsSince(start);
}

MarkerObservation MarkerTracker::Track(const cv::Mat& image) {
  MarkerObservation observation;
  Track(image, observation);
  return observation;
}

}  // namespace tac3d
