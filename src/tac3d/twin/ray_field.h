#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "tac3d/optics/optical_layout.h"

namespace tac3d {

/// The ray of every pixel corner, traced once through the mirrors (and the glass into the
/// silicone when the layout has a gel), so a renderer can sample any point of a pixel by
/// bilinear interpolation instead of tracing it. Corner (i, j) is the pixel point
/// (i - 0.5, j - 0.5).
class RayField {
 public:
  explicit RayField(const OpticalLayout& layout);

  int width() const { return width_; }
  int height() const { return height_; }
  const OpticalLayout& layout() const { return layout_; }

  /// True if all four corners of pixel (u, v) were traced through the same half.
  bool PixelValid(int u, int v) const { return pixel_half_[v * width_ + u] >= 0; }
  ImageHalf PixelHalf(int u, int v) const {
    return static_cast<ImageHalf>(pixel_half_[v * width_ + u]);
  }

  /// The ray at a point of a valid pixel, (fu, fv) in [0, 1]^2 across it: the final ray of
  /// the trace (in the silicone with a gel, else in air after the mirrors).
  void Sample(int u, int v, float fu, float fv, Eigen::Vector3f& origin,
              Eigen::Vector3f& direction) const;

 private:
  int CornerIndex(int i, int j) const { return j * (width_ + 1) + i; }

  OpticalLayout layout_;
  int width_;
  int height_;
  std::vector<Eigen::Vector3f> origin_;     // per corner
  std::vector<Eigen::Vector3f> direction_;  // per corner
  std::vector<std::int8_t> pixel_half_;     // per pixel: -1 invalid, else ImageHalf
};

}  // namespace tac3d
