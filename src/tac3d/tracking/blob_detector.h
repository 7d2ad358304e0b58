#pragma once

#include <cstdint>
#include <limits>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace tac3d {

/// How a dark marker blob is told from the bright film around it and measured. The
/// defaults suit the built-in sensor (dots 4-6 px across, 9-16 px apart, film 150-210 DN).
struct BlobOptions {
  /// A blob's contrast (local background minus its darkest pixel) must reach both this many
  /// grey levels (DN) and this fraction of the local background.
  double min_contrast_dn = 20.0;
  double min_relative_contrast = 0.2;
  /// Pixels darker than the background by less than this fraction of the blob's contrast
  /// get no weight, so the centroid is the core's, not the noise's around it.
  double weight_threshold = 0.15;
  /// Plausible blob: RMS radius along its long axis (px), ratio of its long to its short
  /// axis, and fill (pixels with weight over the area of its 2-sigma ellipse). A merged
  /// pair of dots is too long, speckle noise too sparse.
  double min_spread_px = 0.4;
  double max_spread_px = 3.0;
  double max_elongation = 2.0;
  double min_fill = 0.5;
  /// The 3 x 3 pixels at the centroid must be darker than the background by this fraction
  /// of the contrast on average: a dot has a solid core, noise does not.
  double min_core_darkness = 0.5;
  /// Full-image detection: side of the grey closing that erases the dots to leave the
  /// film's brightness (odd, px, wider than a dot).
  int background_kernel_px = 11;
  /// Full-image detection: area bounds of a candidate's connected component, px.
  int min_area_px = 4;
  int max_area_px = 200;

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// The options' pixel sizes for dots `scale` times as large as the ones they are meant for:
/// the RMS radius bounds and the background closing's half side scaled linearly, the area
/// bounds squared. A scale of 1 or less (or NaN) leaves them as they are.
BlobOptions ScaleBlobOptions(const BlobOptions& options, double scale);

enum class BlobStatus : std::uint8_t {
  kFound,
  kNoBlob,    ///< nothing dark enough in the search disk (or the disk is out of the image)
  kBadShape,  ///< dark, but too small, too large, too long or too sparse for one dot
};
std::string_view ToString(BlobStatus status);

/// One measured blob. `center` is in full-image pixels (OpenCV convention: pixel centres
/// at integers).
struct Blob {
  Eigen::Vector2d center = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  double background_dn = 0.0;  ///< the local background (the ring's median)
  double contrast_dn = 0.0;    ///< local background minus the darkest pixel
  double spread_px = 0.0;    ///< weighted RMS radius along the long axis
  double elongation = 0.0;   ///< long axis over short axis
};

/// Measures the dark blob around a predicted position: the darkest pixel within
/// `search_radius_px` of `predicted`, the local background as the median of a ring just
/// outside `blob_radius_px` around it (16 samples; so uneven light and vignetting cancel), then the
/// darkness-weighted centroid (weight = background - threshold - image, clipped at 0) over
/// the disk of `blob_radius_px`, placed about the darkest pixel (a disk of 8 px or more: about
/// `predicted`) and again about the centroid while it may cut the dot. Uses only pixels inside
/// `roi`; allocates nothing.
/// @param image CV_8UC1. @param roi the part of the image that may be read (one half).
/// @param blob receives the measurement when the status is kFound, and when it is kBadShape (a
/// dark blob measured, implausible as one whole dot: merged, smeared, or cut by roi's border);
/// else untouched.
/// @pre image is CV_8UC1, roi lies in it, radii > 0 (checked by the callers' Validate).
BlobStatus MeasureBlob(const cv::Mat& image,
                       const cv::Rect& roi,
                       const Eigen::Vector2d& predicted,
                       double search_radius_px,
                       double blob_radius_px,
                       const BlobOptions& options,
                       Blob& blob);

/// Asks the processor to fetch the image's pixels in the square about `center` of half side
/// `radius_px` (inside `roi`) into its cache, so a MeasureBlob there that comes after other
/// work does not wait on memory (a camera frame is new to the cache). Reads nothing itself.
/// @pre image is CV_8UC1, roi lies in it.
void PrefetchDisk(const cv::Mat& image, const cv::Rect& roi, const Eigen::Vector2d& center, double radius_px);

/// BlobReachesBorder's sides: the dot reaches the roi's first or last column, its first or last row.
inline constexpr std::uint8_t kBorderColumns = 1;
inline constexpr std::uint8_t kBorderRows = 2;

/// Which borders of `roi` a measured blob's dot reaches (kBorderColumns | kBorderRows, 0 for
/// none): a pixel of the roi's outermost rows or columns within `blob_radius_px` of its centre
/// is darker than halfway from its background to its darkest pixel (the dot's edge; its
/// blurred rim and the vignetting at an image's edge stay above that). The dot's pixels beyond
/// the border are then missing from its centroid, which is pulled inward across that border
/// (and only across it: along the border the cut is symmetric about the dot's centre).
/// @pre image is CV_8UC1, roi lies in it, blob as MeasureBlob found it.
std::uint8_t BlobReachesBorder(const cv::Mat& image,
                               const cv::Rect& roi,
                               const Blob& blob,
                               double blob_radius_px);

/// Finds every plausible dark blob in `roi` (for grid acquisition, not the per-frame
/// path): the film's brightness by a grey closing and a box blur, darkness = film - image,
/// a threshold relative to the film, connected components of plausible area, each then
/// measured by MeasureBlob.
/// @pre image is CV_8UC1 and roi lies in it.
/// @throws Error if the options are invalid.
std::vector<Blob> DetectBlobs(const cv::Mat& image, const cv::Rect& roi, const BlobOptions& options);

}  // namespace tac3d
