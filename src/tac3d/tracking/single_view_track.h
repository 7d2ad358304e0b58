#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "tac3d/source/frame_source.h"
#include "tac3d/tracking/single_view_tracker.h"

namespace tac3d {

/// A marker's state in a single-view track (the CSV's, JSON's and Python's `state`).
enum class TrackedMarkerState : std::uint8_t {
  kTracked,    ///< measured in this frame: its blob's centroid
  kCut,        ///< its dot cut by the image's border (kPartlyOutside): measured along the border
               ///< (its blob's centroid), placed across it by its grid neighbours
  kEstimated,  ///< not measured (hidden, squashed); placed by its measured grid neighbours'
               ///< displacements
  kLost,       ///< not measured and no grid neighbour measured (or the grid lost): no position
};
std::string_view ToString(TrackedMarkerState state);
/// Marker i's state in an observation.
TrackedMarkerState TrackedStateOf(const GridObservation& observation, int i);

/// Frames `first` to `last`, both included.
struct FrameRange {
  std::int64_t first = 0;
  std::int64_t last = 0;
};

/// What SingleViewSourceTracker tracks and measures.
struct SingleViewTrackOptions {
  /// The grid's rows and columns; 0 and 0: the extent of the lattice found in the reference
  /// frame (FindMarkerGrid). At most kMaxMarkerGridSide a side.
  int rows = 0;
  int cols = 0;
  /// The source's frame index of the reference frame (the grid is found in it, its positions
  /// are the markers' reference positions); earlier frames are read and skipped.
  std::int64_t reference_frame = 0;
  /// Frames without contact: the summary gives the markers' position jitter over them (each
  /// range about its own mean: the gel may settle elsewhere after a press).
  std::vector<FrameRange> rest_frames;
  MarkerTrackerOptions tracker;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// What a track measured, over the frames from the reference on.
struct SingleViewTrackSummary {
  std::string source;                ///< the source's description
  std::int64_t reference_frame = 0;
  int rows = 0;
  int cols = 0;
  double pitch_px = 0.0;             ///< median over the markers of the distance to the nearest neighbour
  double dot_radius_px = 0.0;
  int reference_tracked = 0;         ///< markers measured in the reference frame
  std::int64_t frames = 0;           ///< tracked, the reference's included
  std::int64_t bad_frames = 0;       ///< unreadable, skipped
  /// Marker-frames of markers away from the border (not kPartlyOutside, and their position
  /// farther than the dots' radius + 2 px from the image's edge), and those of them not tracked.
  std::int64_t inside = 0;
  std::int64_t inside_untracked = 0;
  int max_lost = 0;                  ///< per frame
  int max_estimated = 0;             ///< per frame
  int max_cut = 0;                   ///< per frame
  int reacquisitions = 0;            ///< frames whose grid was indexed afresh after the reference
  double max_step_px = 0.0;          ///< largest move of a tracked marker between its tracked frames
  int swaps = 0;                     ///< such moves of more than half the pitch (identity swaps)
  std::int64_t deepest_frame = -1;   ///< the frame with the largest displacement from the reference
  double deepest_mean_px = 0.0;      ///< its tracked markers' mean displacement
  double deepest_max_px = 0.0;       ///< and largest
  int rest_frames = 0;               ///< frames of the rest ranges tracked
  /// RMS about each marker's mean over each rest range, pooled over markers and ranges; 0
  /// without rest frames.
  double jitter_x_px = 0.0;
  double jitter_y_px = 0.0;
  double jitter_max_px = 0.0;        ///< the worst marker's RMS in a range (per axis)
};

/// The summary as a JSON object (its fields by name).
nlohmann::json ToJson(const SingleViewTrackSummary& summary);

/// One tracked frame.
struct SingleViewTrackFrame {
  std::int64_t index = 0;    ///< the source's frame index
  double timestamp_s = 0.0;
  cv::Mat image;             ///< the grey frame
  GridObservation markers;   ///< row-major, index = row * cols + col
};

/// A frame as a JSON object: {frame, timestamp_s, acquired, tracked, cut, estimated, lost, markers:
/// [{row, col, x0, y0, x, y, state}]}, x0, y0 the reference position, x, y null for a lost
/// marker.
nlohmann::json ToJson(const SingleViewTrackFrame& frame, const GridObservation& reference, int cols);

/// Opens a source for single-view tracking: an image folder with images of any size, else as
/// OpenFrameSource (a video file, camera:N or /dev/videoN with `camera`'s size and rate).
/// @throws Error as the openers do.
std::unique_ptr<FrameSource> OpenSingleViewSource(const std::string& uri, const CameraSourceOptions& camera = {});

/// Tracks a single-view marker sensor (SingleViewTracker) through a frame source, frame by
/// frame, and keeps the figures of SingleViewTrackSummary as it goes: what `tac3d track`, the
/// Python tracker and live use share.
class SingleViewSourceTracker {
 public:
  /// Reads the source up to the reference frame (earlier frames are skipped) and finds the
  /// grid in it.
  /// @throws Error if the options are invalid, the source fails or ends before the reference
  /// frame, or the reference frame holds no grid (FindMarkerGrid).
  SingleViewSourceTracker(std::unique_ptr<FrameSource> source, const SingleViewTrackOptions& options);
  ~SingleViewSourceTracker();

  /// The next frame, tracked, into `frame` (its storage reused): the reference frame first.
  /// @return kOk; kBadFrame: an unreadable frame was skipped (counted, last_error() says why);
  /// kEnd at the source's end.
  /// @throws Error if the source fails.
  ReadStatus Next(SingleViewTrackFrame& frame);
  /// Why the last Next returned kBadFrame.
  const std::string& last_error() const { return source_->last_error(); }

  const SingleViewTracker& tracker() const { return *tracker_; }
  const GridObservation& reference() const { return tracker_->reference(); }
  int rows() const { return tracker_->grid().rows; }
  int cols() const { return tracker_->grid().cols; }
  /// The figures over the frames tracked so far.
  SingleViewTrackSummary summary() const;

 private:
  struct Jitter;
  void Account(const SingleViewTrackFrame& frame);

  std::unique_ptr<FrameSource> source_;
  SingleViewTrackOptions options_;
  std::optional<SingleViewTracker> tracker_;
  Frame pending_;  // the reference frame until the first Next
  bool reference_given_ = false;
  cv::Size size_;
  SingleViewTrackSummary summary_;
  std::vector<Eigen::Vector2d> last_;  // each marker's last tracked position
  std::unique_ptr<Jitter> jitter_;
};

}  // namespace tac3d
