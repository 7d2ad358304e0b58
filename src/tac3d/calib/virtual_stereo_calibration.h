#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "tac3d/calib/calibration_board.h"
#include "tac3d/calib/dot_grid_detector.h"
#include "tac3d/imagefile/image_decode.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// One image of a calibration set.
struct CalibrationImage {
  std::string name;  ///< file name (for the report and to find the reference view)
  cv::Mat image;     ///< 8-bit grey or BGR; empty if the file could not be read or decoded
  std::string refusal = {};  ///< why the file was not decoded, when `image` is empty (no file name)
};

struct VirtualStereoCalibrationOptions {
  /// Fewer good views than this is an error: six board poses constrain the 9 intrinsics
  /// and the distortion of each half with some redundancy.
  int min_views = 6;
  /// A view whose dots' median edge width (DotGridDetection::edge_width_px) exceeds this
  /// is refused as blurred (3.5 px: a Gaussian blur of sigma ~1.4 px).
  double max_edge_width_px = 3.5;
  /// A view whose reprojection RMS in either half exceeds this after the first
  /// calibration is refused (a misdetected grid), and the calibration is run again.
  double max_view_rms_px = 0.5;
  /// Rounds of the perspective correction of the dot centres (Heikkila 2000): the centroid
  /// of a dot's image is moved by the offset, predicted by the current calibration, between
  /// the centre of the dot's projected ellipse and the projection of its centre.
  int bias_correction_rounds = 2;
  bool progress = false;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// What became of one image.
struct CalibrationViewReport {
  std::string name;
  bool used = false;
  std::string refusal;  ///< why the view was refused (empty when used)
  /// Dot edge width in each half (NaN where the grid was not found), px.
  std::array<double, 2> edge_width_px = {std::numeric_limits<double>::quiet_NaN(),
                                         std::numeric_limits<double>::quiet_NaN()};
  /// Reprojection RMS of the final stereo calibration in each half (NaN if not used), px.
  std::array<double, 2> rms_px = {std::numeric_limits<double>::quiet_NaN(),
                                  std::numeric_limits<double>::quiet_NaN()};
};

/// The two virtual cameras as calibrated.
struct VirtualStereoCalibration {
  std::array<CameraIntrinsics, 2> intrinsics;  ///< indexed by ImageHalf, full-image px
  std::array<Rigid3, 2> sensor_from_vcam;      ///< indexed by ImageHalf
  Rigid3 right_from_left = Rigid3::Identity();
  std::vector<CalibrationViewReport> views;    ///< one per input image, in input order

  struct Summary {
    int images = 0;
    int views_used = 0;
    int views_refused = 0;
    std::array<double, 2> mono_rms_px = {0, 0};  ///< each half calibrated alone, px
    double rms_px = 0;            ///< the joint stereo calibration, both halves, px
    double reference_rms_px = 0;  ///< the reference view placed with the final rig, px
    double seconds = 0;
  } summary;

  /// `nominal` with the calibrated virtual cameras (pose and intrinsics; names, halves and
  /// column ranges kept).
  /// @throws Error if `nominal` has no virtual cameras.
  SensorConfig ApplyTo(const SensorConfig& nominal) const;
};

/// {"images", "views_used", "views_refused", "reprojection_rms_px", "mono_rms_px" [left, right],
///  "reference_rms_px"}: the summary's figures but its time, which each caller names itself.
nlohmann::json ToJson(const VirtualStereoCalibration::Summary& summary);

/// Calibrates the two virtual cameras of a mirror-stereo sensor from images of a dot
/// board (paper section IV.A, before the elastic body is mounted):
/// 1. each image is checked (readable, the camera's size, the grid found in both halves'
///    column ranges, not blurred) and refused with the reason if it fails;
/// 2. each half is calibrated alone (cv::calibrateCamera in full-image coordinates,
///    intrinsics and distortion k1, k2, p1, p2, k3, starting from `nominal`'s), views with
///    a reprojection RMS over max_view_rms_px are refused and the halves calibrated again;
/// 3. the pair is calibrated jointly (cv::stereoCalibrate: relative pose, intrinsics
///    refined);
/// 4. the reference view's board pose relative to the rig is fitted to both halves at once,
///    and its known pose in the sensor frame places both cameras there.
/// Steps 2-4 are repeated after correcting the dot centres' perspective bias.
/// @param images the views, in any order; the reference view is among them.
/// @param nominal supplies the image size, each half's column range and the starting
///        intrinsics.
/// @throws Error if the options are invalid, the reference view is missing or refused, or
/// fewer than min_views views are good (the message lists the refusals).
VirtualStereoCalibration CalibrateVirtualStereo(const std::vector<CalibrationImage>& images,
                                                const CalibrationBoardFile& board,
                                                const SensorConfig& nominal,
                                                const VirtualStereoCalibrationOptions& options = {});

/// Reads a calibration folder: every .png, .jpg, .jpeg, .bmp, .tif or .tiff file in `dir`
/// (not its subfolders), sorted by name. Files that cannot be decoded, or whose header
/// claims more than max_width x max_height pixels (the camera's resolution: such a file is
/// not from this sensor, and decoding it could allocate gigabytes), come back with an empty
/// image and the decoder's refusal, so the calibration refuses them with the reason.
/// @throws Error if `dir` is not a readable directory.
std::vector<CalibrationImage> LoadCalibrationImages(const std::string& dir, int max_width = kMaxImageSidePx,
                                                    int max_height = kMaxImageSidePx);

}  // namespace tac3d
