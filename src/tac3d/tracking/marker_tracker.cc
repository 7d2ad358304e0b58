#include "tac3d/tracking/marker_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {

namespace {

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

// The largest nominal pitch of both halves over the one MarkerTrackerOptions::blob is meant for.
double BlobScale(const std::array<HalfSeed, 2>& seeds, int rows, int cols) {
  double largest_pitch_px = 0;
  for (const HalfSeed& seed : seeds) {
    for (double pitch : CalcGridPitchPx(rows, cols, seed.nominal)) {
      if (std::isfinite(pitch)) largest_pitch_px = std::max(largest_pitch_px, pitch);
    }
  }
  return largest_pitch_px / kBlobOptionsPitchPx;
}

}  // namespace

MarkerTracker::MarkerTracker(const SensorConfig& config, const MarkerTrackerOptions& options)
    : width_(config.camera.intrinsics.width), height_(config.camera.intrinsics.height), options_(options) {
  options_.Validate();
  const int rows = config.markers.rows, cols = config.markers.cols;
  const std::array<HalfSeed, 2> seeds = SeedHalves(config);
  // The blob sizes follow the nominal pitch (the grid trackers' own measure of it).
  MarkerTrackerOptions scaled = options_;
  scaled.blob = blob_ = ScaleBlobOptions(options_.blob, BlobScale(seeds, rows, cols));
  for (ImageHalf which : kImageHalves) {
    const HalfSeed& seed = seeds[static_cast<int>(which)];
    halves_.emplace_back(rows, cols, seed.roi, seed.nominal, scaled, fmt::format("the {} half", ToString(which)));
  }
}

void MarkerTracker::Reset() {
  for (GridTracker& half : halves_) half.Reset();
}

std::optional<cv::Rect> MarkerTracker::CalcReadRegion() const {
  cv::Rect region;
  for (const GridTracker& half : halves_) {
    const std::optional<cv::Rect> part = half.CalcReadRegion();
    if (!part) return std::nullopt;
    region |= *part;
  }
  return region;
}

void MarkerTracker::Track(const cv::Mat& image, MarkerObservation& observation,
                          const std::optional<cv::Rect>& decoded) {
  const auto start = std::chrono::steady_clock::now();
  CheckTrackerImage(image, width_, height_);
  observation.rows = halves_[0].rows();
  observation.cols = halves_[0].cols();
  auto& summary = observation.summary;
  summary = {};
  summary.frame_index = frame_index_++;
  for (int h = 0; h < 2; ++h) {
    HalfObservation& out = observation.halves[h];
    halves_[h].Track(image, out, decoded);
    summary.invalid_markers += static_cast<int>(out.state.size()) - out.valid_markers;
    summary.acquired |= out.acquired;
    summary.grid_lost |= out.grid_lost;
  }
  const int n = observation.rows * observation.cols;
  for (int i = 0; i < n; ++i) summary.paired_markers += observation.paired(i);
  summary.seconds = SecondsSince(start);
}

MarkerObservation MarkerTracker::Track(const cv::Mat& image) {
  MarkerObservation observation;
  Track(image, observation);
  return observation;
}

}  // namespace tac3d
