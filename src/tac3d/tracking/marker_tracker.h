#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/optics/optical_layout.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/tracking/grid_tracker.h"

namespace tac3d {

/// The markers seen in one image half.
using HalfObservation = GridObservation;

/// The largest marker pitch (px) MarkerTrackerOptions::blob's pixel sizes are meant for (the
/// built-in 640 x 480 sensor's); a sensor whose nominal pitch is larger (a 1920 x 1080 Tac3D's,
/// up to about 42 px) has them scaled (MarkerTracker::blob_options).
inline constexpr double kBlobOptionsPitchPx = 16.0;

/// The markers of one frame in both halves. Left and right are paired by index: marker i
/// is the same physical marker in both.
struct MarkerObservation {
  int rows = 0;
  int cols = 0;
  std::array<HalfObservation, 2> halves;  ///< indexed by ImageHalf

  const HalfObservation& half(ImageHalf h) const { return halves[static_cast<int>(h)]; }
  /// Marker i is measured in both halves (triangulable).
  bool paired(int i) const { return halves[0].valid(i) && halves[1].valid(i); }

  struct Summary {
    std::int64_t frame_index = 0;  ///< frames tracked by this tracker before this one
    int paired_markers = 0;
    int invalid_markers = 0;       ///< over both halves
    bool acquired = false;         ///< either half was (re)acquired
    bool grid_lost = false;        ///< either half has no grid
    double seconds = 0.0;          ///< wall time of Track
  } summary;
};

/// Finds the 20 x 20 marker grid in both halves of the camera image and follows it from
/// frame to frame (paper section IV.A): one GridTracker a half, against the nominal
/// sensor's marker pixels in it (see GridTracker for how).
class MarkerTracker {
 public:
  /// Seeded from the sensor's camera model: the mirror model's nominal markers projected into
  /// each virtual camera's columns, or a vendor model's reference pixels in each view's columns
  /// (VendorCameraModelConfig::ViewColumns; the image as the camera delivers it, before the
  /// vendor's flip).
  /// @throws Error if the options are invalid, the config has neither a vendor camera model nor
  /// designed mirrors and virtual cameras, or a marker of the nominal sensor is not seen in its half.
  explicit MarkerTracker(const SensorConfig& config, const MarkerTrackerOptions& options = {});

  /// Measures the markers in a camera frame, writing into `observation` (whose storage is
  /// reused: no allocation once it has been filled once).
  /// @param image CV_8UC1 of the camera's size.
  /// @param decoded the part of `image` decoded (Frame::decoded_region), nullopt: all of it
  ///   (GridTracker::Track).
  /// @throws Error if the image is empty, not CV_8UC1 or not the camera's size.
  void Track(const cv::Mat& image, MarkerObservation& observation,
             const std::optional<cv::Rect>& decoded = std::nullopt);
  /// The same, returning a new observation.
  MarkerObservation Track(const cv::Mat& image);

  /// Forgets the tracked grid: the next frame is acquired afresh.
  void Reset();

  /// The part of the next image Track reads: the bounding box of both halves' regions
  /// (GridTracker::CalcReadRegion), or nullopt while either half is not tracked (the first frame,
  /// after a grid was lost or Reset): the whole image is then read.
  std::optional<cv::Rect> CalcReadRegion() const;

  /// The nominal sensor's marker pixels in a half (the acquisition's prediction).
  const std::vector<Eigen::Vector2d>& nominal_uv(ImageHalf half) const {
    return halves_[static_cast<int>(half)].nominal_uv();
  }
  /// Per marker, the distance to its nearest grid neighbour in nominal_uv, px.
  const std::vector<double>& pitch_px(ImageHalf half) const {
    return halves_[static_cast<int>(half)].pitch_px();
  }
  const MarkerTrackerOptions& options() const { return options_; }
  /// options().blob as used: its pixel sizes scaled by this sensor's largest nominal pitch over
  /// kBlobOptionsPitchPx when that is over 1 (radii and kernel linearly, areas squared): the
  /// largest dots must pass the spread and area bounds and the background kernel be wider.
  const BlobOptions& blob_options() const { return blob_; }

 private:
  int width_ = 0;
  int height_ = 0;
  MarkerTrackerOptions options_;
  BlobOptions blob_;
  std::vector<GridTracker> halves_;  // indexed by ImageHalf
  std::int64_t frame_index_ = 0;
};

}  // namespace tac3d
