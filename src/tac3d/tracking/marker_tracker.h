#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/optics/optical_layout.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/tracking/blob_detector.h"
#include "tac3d/tracking/grid_indexer.h"

namespace tac3d {

/// How the markers are followed from frame to frame. Distances are fractions of each
/// marker's local pitch in the image (the distance to its nearest grid neighbour in the
/// nominal sensor's image, 9-16 px for the built-in sensor), so they hold across the
/// perspective-distorted grid.
struct MarkerTrackerOptions {
  /// In pixels for images whose largest marker pitch is at most kBlobOptionsPitchPx (the
  /// built-in sensor's 640 x 480); in larger ones (a 1920 x 1080 Tac3D's, up to ~42 px) the
  /// tracker scales its sizes by the pitch over that (MarkerTracker::blob_options).
  BlobOptions blob;
  GridIndexOptions index;
  /// A marker's blob is looked for within this distance of its prediction.
  double search_radius = 0.35;
  /// Its centroid must land within this distance of the prediction; matched seeds of an
  /// acquisition must agree with their neighbours' deviations from the affine map as
  /// closely. Rejects a dot merged with a speck beside it (its centroid is pulled off).
  double gate = 0.2;
  /// The disk a centroid is taken over (the local background is read just outside it).
  double blob_radius = 0.45;
  /// Two markers whose blobs are closer than this are one blob: the later one is refused.
  double min_separation = 0.5;
  /// Below this fraction of valid markers a half's grid is lost and re-acquired.
  double min_valid_fraction = 0.5;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// The largest marker pitch (px) MarkerTrackerOptions::blob's pixel sizes are meant for.
inline constexpr double kBlobOptionsPitchPx = 16.0;

/// Why a marker has, or has not, a measurement in a frame.
enum class MarkerState : std::uint8_t {
  kValid,
  kNotFound,      ///< no dark blob near its prediction (hidden, out of view, dark frame)
  kBadShape,      ///< a blob of implausible size or shape (merged, smeared, partly hidden)
  kInconsistent,  ///< the blob lies off the prediction from its grid neighbours' motion
  kConflict,      ///< the blob is already a grid neighbour's
  kGridLost,      ///< the half's grid was not found: nothing measured in it
};
inline constexpr int kMarkerStateCount = 6;
std::string_view ToString(MarkerState state);

/// The markers seen in one image half.
struct HalfObservation {
  /// Per marker, row-major (index = row * cols + col): the sub-pixel centroid in the full
  /// image (px), NaN unless valid.
  std::vector<Eigen::Vector2d> uv;
  /// Per marker, where the tracker takes it to be (px), for display, not a measurement: `uv`
  /// if valid, else its position predicted from its grid neighbours' motion (where it was
  /// looked for), or the nominal sensor's pixel while the half's grid is lost.
  std::vector<Eigen::Vector2d> estimate_uv;
  /// Per marker, its blob's local background (the film around it) and contrast (DN,
  /// MeasureBlob), NaN unless valid: the lighting where the markers are.
  std::vector<double> background_dn;
  std::vector<double> contrast_dn;
  std::vector<MarkerState> state;
  /// The grid was indexed from a full-image detection in this frame (first frame, or
  /// re-acquisition after the tracked grid was lost).
  bool acquired = false;
  /// No grid in this half (too few markers): every marker is kGridLost; acquisition is
  /// tried again on the next frame.
  bool grid_lost = false;
  int valid_markers = 0;
  std::array<int, kMarkerStateCount> state_counts{};  ///< markers per MarkerState

  bool valid(int i) const { return state[i] == MarkerState::kValid; }
};

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
/// frame to frame (paper section IV.A: the displacement field comes from tracking the
/// markers).
///
/// Acquisition (first frame, and whenever a half's grid is lost): every dark blob of the
/// half is detected (DetectBlobs), indexed onto the grid against the nominal sensor's
/// marker pixels (IndexGrid), and the markers it could not match are grown from their
/// matched grid neighbours as in tracking.
///
/// Tracking (every other frame, in small windows only, no allocation): each marker is
/// predicted at its last position moved by the mean motion of its already measured grid
/// neighbours, measured there
/// (MeasureBlob), and accepted if its blob is plausible, near the prediction and not a
/// neighbour's. The grid is grown breadth-first from its outer ring (where the elastic
/// body is thinnest and moves least), so the motion carried inward from neighbour to
/// neighbour keeps identities through up to about one pitch of motion per frame where
/// the motion varies smoothly across the grid. A uniform jump of the whole grid by about a
/// pitch in one frame cannot be told from no motion by any local method; the grid's border
/// reveals it (a side lost, dots beyond the opposite one), and the half is re-acquired.
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
  /// @throws Error if the image is empty, not CV_8UC1 or not the camera's size.
  void Track(const cv::Mat& image, MarkerObservation& observation);
  /// The same, returning a new observation.
  MarkerObservation Track(const cv::Mat& image);

  /// Forgets the tracked grid: the next frame is acquired afresh.
  void Reset();

  /// The nominal sensor's marker pixels in a half (the acquisition's prediction).
  const std::vector<Eigen::Vector2d>& nominal_uv(ImageHalf half) const {
    return halves_[static_cast<int>(half)].nominal;
  }
  /// Per marker, the distance to its nearest grid neighbour in nominal_uv, px.
  const std::vector<double>& pitch_px(ImageHalf half) const {
    return halves_[static_cast<int>(half)].pitch;
  }
  const MarkerTrackerOptions& options() const { return options_; }
  /// options().blob as used: its pixel sizes scaled by this sensor's largest nominal pitch over
  /// kBlobOptionsPitchPx when that is over 1 (radii and kernel linearly, areas squared): the
  /// largest dots must pass the spread and area bounds and the background kernel be wider.
  const BlobOptions& blob_options() const { return blob_; }

 private:
  // Everything one half needs between frames, and its per-frame scratch.
  struct Half {
    cv::Rect roi;
    std::vector<Eigen::Vector2d> nominal;
    std::vector<double> pitch;
    bool tracking = false;
    std::vector<Eigen::Vector2d> estimate;  // last position (measured or predicted), px
    // Scratch.
    std::vector<Eigen::Vector2d> base;      // prediction before the neighbours' correction
    std::vector<Eigen::Vector2d> found;
    std::vector<Eigen::Vector2d> levels;    // found blob's (background, contrast), DN
    std::vector<MarkerState> state;
    std::vector<std::uint8_t> accepted, queued, tries;
    std::vector<int> queue;
  };

  void AcquireHalf(const cv::Mat& image, Half& half) const;
  // Keeps, of the accepted markers, the largest set connected through grid neighbours whose
  // deviations from their base agree; the others are to be grown again.
  void KeepLargestConsistentSeeds(Half& half) const;
  void TrackHalf(const cv::Mat& image, Half& half) const;
  // A jump of the whole grid by about a pitch, which tracking takes for no motion with every
  // identity one off: a side of the border ring mostly not found and dots found one pitch
  // beyond the opposite side. Probes only when a side is mostly lost.
  bool GridJumped(const cv::Mat& image, const Half& half) const;
  // Grows the accepted set breadth-first from the queue: see the class comment.
  void Grow(const cv::Mat& image, Half& half, int head, int tail) const;
  // Prediction of marker i: its base, moved by the mean unexpected motion (found - base)
  // of its accepted neighbours.
  Eigen::Vector2d Predict(const Half& half, int i) const;
  int CountValid(const Half& half) const;
  // Ends a frame of a half: every marker's estimate for the next one.
  void Commit(Half& half) const;
  // Calls f(j) for each of marker i's (up to 8) grid neighbours j.
  template <typename F>
  void ForNeighbours(int i, F&& f) const;

  SensorConfig config_;
  MarkerTrackerOptions options_;
  BlobOptions blob_;
  int rows_ = 0;
  int cols_ = 0;
  // Marker i's grid neighbours: neighbours_[neighbour_begin_[i] .. neighbour_begin_[i + 1]),
  // a table rather than a division per visit (three visits a marker a frame).
  std::vector<int> neighbour_begin_, neighbours_;
  std::array<Half, 2> halves_;
  std::int64_t frame_index_ = 0;
};

}  // namespace tac3d
