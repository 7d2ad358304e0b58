#include "tac3d/twin/ray_field.h"

#include "tac3d/twin/vendor_optics.h"

namespace tac3d {

std::optional<HalfRay> MirrorOptics::Trace(const Eigen::Vector2d& pixel) const {
  const TracedRay r = TracePixel(layout_, pixel);
  if (!r.ok()) return std::nullopt;
  return HalfRay{r.half, layout_.layers.has_gel ? r.in_silicone : r.in_air};
}

std::optional<Eigen::Vector2d> MirrorOptics::Project(ImageHalf half, const Eigen::Vector3d& p_in_sensor) const {
  return ProjectPoint(layout_, half, p_in_sensor);
}

std::unique_ptr<PixelOptics> MakeMarkerOptics(const SensorConfig& config) {
  if (config.vendor_camera) return std::make_unique<VendorOptics>(config);
  return std::make_unique<MirrorOptics>(config.MakeOpticalLayout(true));
}

RayField::RayField(std::unique_ptr<PixelOptics> optics)
    : optics_(std::move(optics)), width_(optics_->intrinsics().width), height_(optics_->intrinsics().height) {
  const int corners = (width_ + 1) * (height_ + 1);
  origin_.resize(corners);
  direction_.resize(corners);
  std::vector<std::int8_t> corner_half(corners, -1);
  for (int j = 0; j <= height_; ++j) {
    for (int i = 0; i <= width_; ++i) {
      const std::optional<HalfRay> r = optics_->Trace({i - 0.5, j - 0.5});
      if (!r) continue;
      const int k = CornerIndex(i, j);
      origin_[k] = r->ray.origin.cast<float>();
      direction_[k] = r->ray.direction.cast<float>();
      corner_half[k] = static_cast<std::int8_t>(r->half);
    }
  }
  pixel_half_.assign(width_ * height_, -1);
  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      const std::int8_t h = corner_half[CornerIndex(u, v)];
      if (h >= 0 && corner_half[CornerIndex(u + 1, v)] == h &&
          corner_half[CornerIndex(u, v + 1)] == h && corner_half[CornerIndex(u + 1, v + 1)] == h) {
        pixel_half_[v * width_ + u] = h;
      }
    }
  }
}

void RayField::Sample(int u, int v, float fu, float fv, Eigen::Vector3f& origin,
                      Eigen::Vector3f& direction) const {
  const int k00 = CornerIndex(u, v), k10 = k00 + 1;
  const int k01 = k00 + width_ + 1, k11 = k01 + 1;
  const float w00 = (1 - fu) * (1 - fv), w10 = fu * (1 - fv), w01 = (1 - fu) * fv, w11 = fu * fv;
  origin = w00 * origin_[k00] + w10 * origin_[k10] + w01 * origin_[k01] + w11 * origin_[k11];
  direction = w00 * direction_[k00] + w10 * direction_[k10] + w01 * direction_[k01] +
              w11 * direction_[k11];
}

}  // namespace tac3d
