#pragma once

#include <limits>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/calib/calibration_board.h"
#include "tac3d/optics/camera.h"

namespace tac3d {

/// More candidate blobs than this many per board dot in a roi and the grid is not looked
/// for: the grid finder's time grows steeply with the candidates (0.8 s at 350, 10 s at
/// 700, minutes for the ~4000 of a frame of pure noise), and so many are noise or clutter.
inline constexpr int kMaxDotGridBlobsPerDot = 4;

/// The board's dots found in one part of an image.
struct DotGridDetection {
  bool found = false;
  /// Dot centres in full-image pixels (pixel centres at integer coordinates), in the
  /// board's row-major order (CalibrationBoard::DotCenters), sub-pixel refined.
  std::vector<Eigen::Vector2d> centers;
  /// How blurred the dots are: the median over the dots of (dot contrast) / (steepest
  /// intensity gradient at its rim), px. About 2.5 sigma for a Gaussian blur of sigma px;
  /// ~1.5 px for a sharp 8-bit image.
  double edge_width_px = std::numeric_limits<double>::quiet_NaN();
  /// Candidate blobs in the roi (the grid finder's input); the grid is not looked for if
  /// there are fewer than the board's dots or more than kMaxDotGridBlobsPerDot per dot.
  int blobs = 0;
};

/// Finds the board in `roi` of an 8-bit grey image (cv::findCirclesGrid on the blobs of a
/// cv::SimpleBlobDetector, unless they are too few or too many), puts the dots
/// in a canonical order, and refines each centre to sub-pixel accuracy.
///
/// Order: of the orderings the grid's symmetries allow (a symmetric grid looks the same
/// turned by 180 deg), the one whose rows run to the image's right and whose columns run
/// down, so both halves of a mirror-stereo image and the reference placement agree.
/// Refinement: the darkness-weighted centroid over a window of half the nearest-dot
/// distance around each dot (mapped into the image by the affine fit of the dot's grid
/// neighbours), darkness = 1 - intensity / white, the white level a plane fitted to the
/// window's outer ring (so vignetting does not pull the centroid); iterated three times.
/// This is the centroid of the dot's image, off the image of its centre by a perspective
/// bias (DotCentroidBias) that grows as the dot's radius squared.
/// @pre `gray` is CV_8UC1 and `roi` lies inside it.
DotGridDetection DetectDotGrid(const cv::Mat& gray, const cv::Rect& roi,
                               const CalibrationBoard& board);

/// The perspective bias of a dot's centroid (Heikkila 2000): the image of the dot's rim is
/// an ellipse (the circle through the board -> image homography) whose centre, which a
/// centroid finds, is not the image of the dot's centre. Returns centre of the ellipse
/// minus image of the centre, px; distortion is applied to both points, not to the shape.
/// @param cam_from_board the board's pose in the camera frame.
/// @param dot_in_board the dot's centre, board frame (z = 0).
/// @param radius_mm the dot's radius.
/// @pre the dot is in front of the camera.
Eigen::Vector2d DotCentroidBias(const CameraIntrinsics& camera, const Rigid3& cam_from_board,
                                const Eigen::Vector3d& dot_in_board, double radius_mm);

}  // namespace tac3d
