#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "tac3d/optics/optical_layout.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// The final ray of a pixel point and the image half (view) it belongs to.
struct HalfRay {
  ImageHalf half = ImageHalf::kLeft;
  Ray ray;  ///< sensor frame: in the silicone for a gel, else in air
};

/// The camera optics the twin renders through: the ray of every point of the camera's image
/// (as the camera delivers it) and the pixel of a point seen in a half.
class PixelOptics {
 public:
  virtual ~PixelOptics() = default;
  virtual const CameraIntrinsics& intrinsics() const = 0;
  /// nullopt where the pixel sees no marker layer (outside both halves' light paths).
  virtual std::optional<HalfRay> Trace(const Eigen::Vector2d& pixel) const = 0;
  virtual std::optional<Eigen::Vector2d> Project(ImageHalf half, const Eigen::Vector3d& p_in_sensor) const = 0;
};

/// The twin's mirror model: the camera through the four mirrors (TracePixel, ProjectPoint).
class MirrorOptics : public PixelOptics {
 public:
  explicit MirrorOptics(const OpticalLayout& layout) : layout_(layout) {}
  const CameraIntrinsics& intrinsics() const override { return layout_.intrinsics; }
  std::optional<HalfRay> Trace(const Eigen::Vector2d& pixel) const override;
  std::optional<Eigen::Vector2d> Project(ImageHalf half, const Eigen::Vector3d& p_in_sensor) const override;
  const OpticalLayout& layout() const { return layout_; }

 private:
  OpticalLayout layout_;
};

/// The optics of a sensor's markers: a vendor camera model's (VendorOptics) when the config has
/// one, else the mirror model's with the gel.
/// @throws Error if the config has neither a vendor model nor designed mirrors.
std::unique_ptr<PixelOptics> MakeMarkerOptics(const SensorConfig& config);

/// The ray of every pixel corner, traced once through the optics (for the mirror model the
/// mirrors, and the glass into the silicone when the layout has a gel), so a renderer can
/// sample any point of a pixel by bilinear interpolation instead of tracing it. Corner (i, j)
/// is the pixel point (i - 0.5, j - 0.5).
class RayField {
 public:
  explicit RayField(std::unique_ptr<PixelOptics> optics);
  explicit RayField(const OpticalLayout& layout) : RayField(std::make_unique<MirrorOptics>(layout)) {}

  int width() const { return width_; }
  int height() const { return height_; }
  const PixelOptics& optics() const { return *optics_; }

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

  std::unique_ptr<PixelOptics> optics_;
  int width_;
  int height_;
  std::vector<Eigen::Vector3f> origin_;     // per corner
  std::vector<Eigen::Vector3f> direction_;  // per corner
  std::vector<std::int8_t> pixel_half_;     // per pixel: -1 invalid, else ImageHalf
};

}  // namespace tac3d
