#pragma once

#include <vector>

#include <Eigen/Core>

namespace tac3d {

/// How detections are matched to the marker grid when it is first acquired.
struct GridIndexOptions {
  /// The largest global offset of the grid from its prediction that the vote looks for, px.
  double max_offset_px = 24.0;
  /// Peaks of the offset vote tried as starting points (the grid is periodic, so the true
  /// offset and its one-pitch neighbours all get votes; the grid's border decides).
  int hypotheses = 5;
  /// A detection matches a predicted marker within this fraction of the local pitch.
  double match_gate = 0.3;
  int max_iterations = 15;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// One way of matching the detections to the grid, and the affine map that explains it.
struct GridIndex {
  std::vector<int> detection_of_marker;  ///< per marker: the index of its detection, -1 if none
  /// image = affine * [predicted; 1], fitted on the matches (px).
  Eigen::Matrix<double, 2, 3> affine = Eigen::Matrix<double, 2, 3>::Identity();
  struct Summary {
    Eigen::Vector2d start_offset_px = Eigen::Vector2d::Zero();  ///< the vote peak it grew from
    int iterations = 0;
    int matches = 0;
    double rms_px = 0.0;  ///< of the matches about the affine map
  } summary;

  Eigen::Vector2d Map(const Eigen::Vector2d& predicted) const {
    return affine.leftCols<2>() * predicted + affine.col(2);
  }
};

/// Indexes detected blobs onto the marker grid: votes for the global offset between the
/// predicted marker pixels and the detections, then from each of the strongest vote peaks
/// alternates one-to-one nearest-neighbour matching within a gate and a least-squares
/// affine fit (iterative closest point), over a disk that starts where the offset fits
/// and grows to the whole grid. Robust to an offset of up to `max_offset_px`, a few
/// degrees of rotation, a few percent of scale, missing and spurious blobs.
///
/// The grid is periodic: a start one pitch off also matches most markers, and under a
/// dent or shear it can match more than the right one (the displaced markers fall on
/// their neighbours' places). So every distinct result is returned, most matches first,
/// for the caller to judge with more than the detections (MarkerTracker grows each from
/// the image and keeps the one that measures the most markers).
/// @param detections blob centres (px). @param predicted marker pixels of the nominal sensor.
/// @param pitch_px per marker, the distance to its nearest grid neighbour in `predicted`.
/// @return at most `hypotheses` distinct indexings with at least 3 matches not on a line;
/// empty if there is none.
/// @throws Error if the options are invalid or predicted and pitch_px differ in size.
std::vector<GridIndex> IndexGrid(const std::vector<Eigen::Vector2d>& detections,
                                 const std::vector<Eigen::Vector2d>& predicted,
                                 const std::vector<double>& pitch_px,
                                 const GridIndexOptions& options);

}  // namespace tac3d
