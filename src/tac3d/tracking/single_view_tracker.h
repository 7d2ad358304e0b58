#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/tracking/grid_tracker.h"

namespace tac3d {

/// A marker grid found in one image: rows x cols markers, row 0 at the top, column 0 at the
/// left.
struct MarkerGrid {
  int rows = 0;
  int cols = 0;
  /// Per marker, row-major: its blob's centroid, or for a marker with no whole blob (cut by
  /// the image's border, hidden) where the lattice of its neighbours puts it (px).
  std::vector<Eigen::Vector2d> uv;
  /// Per marker: its blob was detected whole (not cut by the image's border).
  std::vector<std::uint8_t> detected;
  /// The dots' radius: twice the median RMS radius of the detected blobs (a uniform disk's
  /// edge), px.
  double dot_radius_px = 0.0;
  /// The blob options the grid was detected with, sized to the dots (SizeBlobOptionsToDots).
  BlobOptions blob;
  Eigen::Vector2d column_step_px = Eigen::Vector2d::Zero();  ///< from one column to the next
  Eigen::Vector2d row_step_px = Eigen::Vector2d::Zero();     ///< from one row to the next
};

/// Blob options for dots of RMS radius `spread_px`. The defaults suit Tac3D's dots (RMS radius
/// up to 1.5 px); larger dots scale the pixel sizes with them (ScaleBlobOptions: the spread and
/// area bounds, the background closing), and allow an axis ratio of 4: a dot
/// many pixels across squashed at a contact's edge reaches 3-4 (a GelSight Mini's at its
/// deepest press), and the centroid's disk, narrowed to the dot, cannot hold a neighbour's.
BlobOptions SizeBlobOptionsToDots(const BlobOptions& options, double spread_px);

/// Finds the grid of dark markers in an image: every dark blob (DetectBlobs, first with room
/// for dots up to a sixteenth of the image's side to measure their size, then again with
/// SizeBlobOptionsToDots of their median RMS radius), the two
/// lattice steps (the medians of the offsets to each blob's nearest neighbours along
/// either image axis), each blob's lattice coordinates by walking from the blob nearest the
/// image's centre one step at a time (a blob matches within 0.3 of the median nearest
/// distance of where the step predicts it), and the grid's extent. Blobs off the lattice
/// (specks, the object's texture) are left out. Dots cut by the image's border, which detection
/// mostly refuses for their shape, are looked for at the lattice's nodes around it (an affine
/// map of the whole blobs): a dark blob there that reaches the border and lies along it where
/// the node is counts as a marker seen.
/// @param rows, cols the grid's size, or 0 for the extent of the markers seen. Given, the
/// window of that size holding the most markers seen is taken (of equals, the most whole dots,
/// then the most centred): never a row or column wholly outside the image while one partly
/// inside is left out.
/// @pre image is CV_8UC1. The grid's axes lie within about 30 deg of the image's.
/// @throws Error if fewer than 4 blobs are on a lattice, rows / cols is negative or over
/// kMaxMarkerGridSide, or a given grid holds under half as many blobs as it has markers.
/// The most markers a side FindMarkerGrid takes (a TactileFrame's kMaxGridSide).
inline constexpr int kMaxMarkerGridSide = 100;

MarkerGrid FindMarkerGrid(const cv::Mat& image, int rows, int cols, const BlobOptions& blob = {});

/// Tracks the markers of a single-view sensor (one camera looking at a marked gel, such as
/// a GelSight Mini; unlike Tac3D's mirrored pair): the grid is found in a reference frame
/// (FindMarkerGrid), which also gives each marker's reference position, then a GridTracker
/// over the whole image follows it, with the Tac3D path's robustness: lost and re-found
/// markers flagged, no identity swaps, markers cut by the image's border flagged
/// (kPartlyOutside) rather than measured with a biased centroid, the grid re-acquired
/// against the reference one when it is lost. The blob options are the grid's (sized to its
/// dots), and the disk a centroid is taken over is narrowed
/// from `options.blob_radius` to the dots' radius plus 2.5 px where that is smaller: a
/// GelSight's dots span a third of the pitch (Tac3D's nearly half), and a wider disk takes in
/// the pressing object's texture around them.
class SingleViewTracker {
 public:
  /// Finds the grid in `reference` and tracks that frame.
  /// @param rows, cols as FindMarkerGrid's.
  /// @throws Error as FindMarkerGrid and GridTracker do, or if the reference image is not
  /// CV_8UC1 or empty.
  SingleViewTracker(const cv::Mat& reference, int rows, int cols, const MarkerTrackerOptions& options = {});

  /// Measures the markers in a frame of the reference's size, into `observation` (storage
  /// reused).
  /// @throws Error if the image is empty, not CV_8UC1 or not the reference's size.
  void Track(const cv::Mat& image, GridObservation& observation);

  const MarkerGrid& grid() const { return grid_; }
  /// The reference frame's observation: each marker's reference position is its
  /// estimate_uv (measured where the marker is valid).
  const GridObservation& reference() const { return reference_; }
  /// The grid's pitch at marker i (px).
  double pitch_px(int i) const { return tracker_.pitch_px()[i]; }

 private:
  MarkerGrid grid_;
  MarkerTrackerOptions options_;  // sized to the grid's dots
  GridTracker tracker_;
  GridObservation reference_;
};

}  // namespace tac3d
