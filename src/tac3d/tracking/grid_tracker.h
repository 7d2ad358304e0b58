#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/tracking/blob_detector.h"
#include "tac3d/tracking/grid_indexer.h"

namespace tac3d {

/// How the markers are followed from frame to frame. Distances are fractions of each
/// marker's local pitch in the image (the distance to its nearest grid neighbour in the
/// nominal grid, 9-16 px for the built-in sensor), so they hold across a
/// perspective-distorted grid.
struct MarkerTrackerOptions {
  /// In pixels for a grid whose largest pitch is at most 16 px (the built-in 640 x 480 sensor);
  /// MarkerTracker scales them for larger ones (kBlobOptionsPitchPx), the single-view tracker
  /// sizes them to the dots it measures (SizeBlobOptionsToDots).
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
  /// Below this fraction of valid markers a grid is lost and re-acquired.
  double min_valid_fraction = 0.5;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// Why a marker has, or has not, a measurement in a frame.
enum class MarkerState : std::uint8_t {
  kValid,
  kNotFound,      ///< no dark blob near its prediction (hidden, out of view, dark frame)
  kBadShape,      ///< a blob of implausible size or shape (merged, smeared, partly hidden)
  kInconsistent,  ///< the blob lies off the prediction from its grid neighbours' motion
  kConflict,      ///< the blob is already a grid neighbour's
  kGridLost,      ///< the grid was not found: nothing measured in it
  kPartlyOutside, ///< the dot reaches the image's (or half's) border: its centroid would be biased
                  ///< across the border (BlobReachesBorder), so it is not valid; its estimate_uv
                  ///< is its blob's centroid along the border, its neighbours' placement across it
};
inline constexpr int kMarkerStateCount = 7;
std::string_view ToString(MarkerState state);

/// The markers of one grid seen in one view (a half of Tac3D's image, or a single-view
/// sensor's whole image).
struct GridObservation {
  /// Per marker, row-major (index = row * cols + col): the sub-pixel centroid in the full
  /// image (px), NaN unless valid.
  std::vector<Eigen::Vector2d> uv;
  /// Per marker, where the tracker takes it to be (px), for display, not a measurement: `uv`
  /// if valid, else where its measured grid neighbours' displacements from the nominal grid
  /// put it (else where it was looked for), or the nominal grid's pixel while the grid is
  /// lost.
  std::vector<Eigen::Vector2d> estimate_uv;
  /// Per marker, whether `estimate_uv` is backed by this frame: valid, cut by the border and
  /// measured along it (kPartlyOutside), or predicted from at least one grid neighbour measured
  /// in it (else the marker's last position, or nominal).
  std::vector<std::uint8_t> supported;
  /// Per marker, its blob's local background (the film around it) and contrast (DN,
  /// MeasureBlob), NaN unless valid: the lighting where the markers are.
  std::vector<double> background_dn;
  std::vector<double> contrast_dn;
  std::vector<MarkerState> state;
  /// The grid was indexed from a full-image detection in this frame (first frame, or
  /// re-acquisition after the tracked grid was lost).
  bool acquired = false;
  /// No grid in this view (too few markers): every marker is kGridLost; acquisition is
  /// tried again on the next frame.
  bool grid_lost = false;
  int valid_markers = 0;
  std::array<int, kMarkerStateCount> state_counts{};  ///< markers per MarkerState

  bool valid(int i) const { return state[i] == MarkerState::kValid; }
};

/// The trackers' check of a camera frame.
/// @throws Error if the image is empty, not CV_8UC1, or not width x height px.
void CheckTrackerImage(const cv::Mat& image, int width, int height);

/// Per marker of a rows x cols grid (row-major `nominal` pixels), the distance to its nearest
/// grid neighbour (left, right, up or down), px; infinite for a marker with none.
/// @pre nominal holds rows * cols points.
std::vector<double> CalcGridPitchPx(int rows, int cols, const std::vector<Eigen::Vector2d>& nominal);

/// Finds a rows x cols marker grid in a region of the image and follows it from frame to
/// frame (paper section IV.A: the displacement field comes from tracking the markers). The
/// building block of MarkerTracker (one per image half) and SingleViewTracker (one image).
///
/// Acquisition (first frame, and whenever the grid is lost): every dark blob of the
/// region is detected (DetectBlobs), indexed onto the grid against the nominal marker
/// pixels (IndexGrid), and the markers it could not match are grown from their matched
/// grid neighbours as in tracking.
///
/// Tracking (every other frame, in small windows only, no allocation): each marker is
/// predicted at its last position moved by the mean motion of its already measured grid
/// neighbours, measured there (MeasureBlob), and accepted if its blob is plausible, near the
/// prediction, not a neighbour's and not cut by the region's border. The grid is grown
/// breadth-first from its outer ring (where the elastic body is thinnest and moves least),
/// so the motion carried inward from neighbour to neighbour keeps identities through up to
/// about one pitch of motion per frame where the motion varies smoothly across the grid. A
/// uniform jump of the whole grid by about a pitch in one frame cannot be told from no
/// motion by any local method; the grid's border reveals it (a side lost, dots beyond the
/// opposite one), and the grid is re-acquired.
class GridTracker {
 public:
  /// @param nominal per marker, row-major, the expected pixel (the acquisition's
  /// prediction; a marker of a border row may lie just outside `roi`).
  /// @param what names the grid in messages ("the left half").
  /// @throws Error if the options are invalid, the grid has fewer than 2 markers, nominal is not rows * cols
  /// finite points, roi is empty, or grid neighbours are closer than 2 px.
  GridTracker(int rows, int cols, const cv::Rect& roi, std::vector<Eigen::Vector2d> nominal,
              const MarkerTrackerOptions& options, const std::string& what);

  /// Measures the grid's markers in `image` (CV_8UC1 containing roi), writing into `out`
  /// (whose storage is reused: no allocation once it has been filled once).
  /// @param decoded the part of `image` decoded (Frame::decoded_region), nullopt: all of it.
  ///   Nothing outside it is read: a blob reaching its edge is cut as by the roi's. A grid lost in
  ///   a partly decoded image is not acquired in it: it stays lost until the next whole image.
  void Track(const cv::Mat& image, GridObservation& out, const std::optional<cv::Rect>& decoded = std::nullopt);

  /// The part of the next image Track reads (within roi), for a decoder that decodes no more
  /// (JpegGreyDecoder): each marker's estimate with its search radius, twice its blob radius and
  /// a pitch of motion around it (a marker that moves further in one frame is lost to tracking
  /// anyway). nullopt while the grid is not tracked (first frame, grid lost): acquisition reads
  /// all of roi.
  std::optional<cv::Rect> CalcReadRegion() const;

  /// Forgets the tracked grid: the next frame is acquired afresh.
  void Reset() { tracking_ = false; }

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  const cv::Rect& roi() const { return roi_; }
  /// The nominal marker pixels (the acquisition's prediction).
  const std::vector<Eigen::Vector2d>& nominal_uv() const { return nominal_; }
  /// Per marker, the distance to its nearest grid neighbour in nominal_uv, px.
  const std::vector<double>& pitch_px() const { return pitch_; }

 private:
  void Acquire(const cv::Mat& image);
  // Keeps, of the accepted markers, the largest set connected through grid neighbours whose
  // deviations from their base agree; the others are to be grown again.
  void KeepLargestConsistentSeeds();
  void TrackGrid(const cv::Mat& image);
  // A jump of the whole grid by about a pitch, which tracking takes for no motion with every
  // identity one off: a side of the border ring mostly not found and dots found one pitch
  // beyond the opposite side. Probes only when a side is mostly lost.
  bool GridJumped(const cv::Mat& image) const;
  // Grows the accepted set breadth-first from the queue: see the class comment.
  void Grow(const cv::Mat& image, int head, int tail);
  // The state a found blob gives marker i: kValid, or why it is refused.
  MarkerState Judge(int i, const Blob& blob, const Eigen::Vector2d& prediction) const;
  // The state a blob cut by the roi's `sides` (BlobReachesBorder) gives marker i: kPartlyOutside,
  // its blob kept for the coordinate along the border (found_, cut_), or kInconsistent if that
  // coordinate is off the prediction by more than the gate.
  MarkerState JudgeCut(int i, const Blob& blob, std::uint8_t sides, const Eigen::Vector2d& prediction);
  // Prediction of marker i: its base, moved by the mean unexpected motion (found - base)
  // of its accepted neighbours.
  Eigen::Vector2d Predict(int i) const;
  int CountValid() const;
  // Ends a frame: every marker's estimate for the next one.
  void Commit();
  // Calls f(j) for each of marker i's (up to 8) grid neighbours j.
  template <typename F>
  void ForNeighbours(int i, F&& f) const;

  int rows_ = 0;
  int cols_ = 0;
  cv::Rect roi_;
  cv::Rect frame_roi_;  // the part of roi decoded in the image being tracked
  std::vector<Eigen::Vector2d> nominal_;
  std::vector<double> pitch_;
  MarkerTrackerOptions options_;
  // Marker i's grid neighbours: neighbours_[neighbour_begin_[i] .. neighbour_begin_[i + 1]),
  // a table rather than a division per visit (three visits a marker a frame).
  std::vector<int> neighbour_begin_, neighbours_;
  bool tracking_ = false;
  std::vector<Eigen::Vector2d> estimate_;  // last position (measured or predicted), px
  std::vector<std::uint8_t> supported_;    // estimate_ backed by this frame
  // Scratch.
  std::vector<Eigen::Vector2d> base_;      // prediction before the neighbours' correction
  std::vector<Eigen::Vector2d> found_;     // accepted markers' centroids, and cut ones' (cut_)
  std::vector<Eigen::Vector2d> levels_;    // found blob's (background, contrast), DN
  std::vector<MarkerState> state_;
  std::vector<std::uint8_t> accepted_, queued_, tries_;
  std::vector<std::uint8_t> cut_;           // a kPartlyOutside marker's BlobReachesBorder sides
  std::vector<int> queue_;
};

}  // namespace tac3d
