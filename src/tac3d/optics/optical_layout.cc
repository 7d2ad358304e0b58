#include "tac3d/optics/optical_layout.h"

#include <cmath>
#include <limits>
#include <vector>

namespace tac3d {
namespace {

constexpr double kMinTravelMm = 1e-9;

// The nearest hit of a ray on a mirror's reflective side.
std::optional<double> HitReflectiveSide(const Rectangle3& mirror, const Ray& ray) {
  if (ray.direction.dot(mirror.normal()) >= 0.0) return std::nullopt;
  return mirror.Intersect(ray, kMinTravelMm);
}

// A horizontal layer of constant refractive index crossed by the unfolded ray.
struct Layer {
  double thickness_mm;
  double index;
};

}  // namespace

std::string_view ToString(ImageHalf half) {
  return half == ImageHalf::kLeft ? "left" : "right";
}

std::string_view ToString(TraceStatus status) {
  switch (status) {
    case TraceStatus::kOk: return "ok";
    case TraceStatus::kMissedMirrors: return "missed the mirrors";
    case TraceStatus::kMissedOuterMirror: return "missed the outer mirror";
    case TraceStatus::kBlocked: return "blocked by an inner mirror";
    case TraceStatus::kMissedGel: return "does not reach the glass";
    case TraceStatus::kTotalReflection: return "total internal reflection";
  }
  return "unknown";
}

Rigid3 OpticalLayout::SensorFromVirtualCamera(ImageHalf half) const {
  const MirrorPair& p = pair(half);
  const Eigen::Affine3d unfold =
      p.outer.plane().ReflectionTransform() * p.inner.plane().ReflectionTransform();
  Rigid3 result = Rigid3::Identity();
  result.linear() = unfold.linear() * sensor_from_cam.linear();
  result.translation() = unfold * sensor_from_cam.translation();
  return result;
}

TracedRay TraceCameraRay(const OpticalLayout& layout, const Ray& ray) {
  TracedRay out;
  double best_t = std::numeric_limits<double>::infinity();
  for (ImageHalf half : kImageHalves) {
    const auto t = HitReflectiveSide(layout.pair(half).inner, ray);
    if (t && *t < best_t) {
      best_t = *t;
      out.half = half;
    }
  }
  if (!std::isfinite(best_t)) return out;

  const MirrorPair& pair = layout.pair(out.half);
  out.inner_hit = ray.At(best_t);
  const Ray to_outer{out.inner_hit, ReflectDirection(ray.direction, pair.inner.normal())};
  const auto t_outer = HitReflectiveSide(pair.outer, to_outer);
  if (!t_outer) {
    out.status = TraceStatus::kMissedOuterMirror;
    return out;
  }
  out.outer_hit = to_outer.At(*t_outer);
  out.in_air = Ray{out.outer_hit, ReflectDirection(to_outer.direction, pair.outer.normal())};

  // The inner mirrors stand between the outer mirrors and the body: the beam that just
  // grazes them (paper constraint 3) must not be cut.
  for (ImageHalf half : kImageHalves) {
    const Rectangle3& inner = layout.pair(half).inner;
    const auto t = inner.Intersect(out.in_air, kMinTravelMm);
    const double to_glass_z = layout.layers.has_gel ? layout.layers.glass_bottom_z_mm : 0.0;
    if (t && out.in_air.At(*t).z() < to_glass_z) {
      out.status = TraceStatus::kBlocked;
      return out;
    }
  }

  if (!layout.layers.has_gel) {
    out.status = TraceStatus::kOk;
    return out;
  }
  if (out.in_air.direction.z() <= 0.0) {
    out.status = TraceStatus::kMissedGel;
    return out;
  }
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const double t_glass = (layout.layers.glass_bottom_z_mm - out.in_air.origin.z()) / out.in_air.direction.z();
  if (t_glass < 0.0) {
    out.status = TraceStatus::kMissedGel;
    return out;
  }
  const Eigen::Vector3d glass_entry = out.in_air.At(t_glass);
  const auto in_glass = RefractDirection(out.in_air.direction, up, 1.0, layout.layers.glass_index);
  if (!in_glass) {
    out.status = TraceStatus::kTotalReflection;
    return out;
  }
  const double t_top = -glass_entry.z() / in_glass->z();
  const Eigen::Vector3d silicone_entry = glass_entry + t_top * *in_glass;
  const auto in_silicone =
      RefractDirection(*in_glass, up, layout.layers.glass_index, layout.layers.silicone_index);
  if (!in_silicone) {
    out.status = TraceStatus::kTotalReflection;
    return out;
  }
  out.in_silicone = Ray{silicone_entry, *in_silicone};
  out.status = TraceStatus::kOk;
  return out;
}

TracedRay TracePixel(const OpticalLayout& layout, const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d d_in_cam = layout.intrinsics.Unproject(pixel);
  return TraceCameraRay(layout, Ray{layout.sensor_from_cam.translation(),
                                    layout.sensor_from_cam.linear() * d_in_cam});
}

std::optional<Eigen::Vector2d> ProjectPoint(const OpticalLayout& layout,
                                            ImageHalf half,
                                            const Eigen::Vector3d& p_in_sensor) {
  return ProjectThroughLayers(layout.SensorFromVirtualCamera(half), layout.intrinsics,
                              layout.layers, p_in_sensor);
}

std::optional<Eigen::Vector2d> ProjectThroughLayers(const Rigid3& sensor_from_vcam,
                                                    const CameraIntrinsics& intrinsics,
                                                    const FlatLayers& layers,
                                                    const Eigen::Vector3d& p_in_sensor) {
  const Eigen::Vector3d center = sensor_from_vcam.translation();
  const double z0 = center.z();
  const double z1 = p_in_sensor.z();
  if (z1 <= z0) return std::nullopt;

  // The layers the unfolded ray crosses between the virtual camera and the point.
  std::vector<Layer> crossed;
  if (!layers.has_gel) {
    crossed.push_back({z1 - z0, 1.0});
  } else {
    const double zg = layers.glass_bottom_z_mm;
    auto add = [&](double lo, double hi, double index) {
      lo = std::max(lo, z0);
      hi = std::min(hi, z1);
      if (hi > lo) crossed.push_back({hi - lo, index});
    };
    add(-std::numeric_limits<double>::infinity(), zg, 1.0);
    add(zg, 0.0, layers.glass_index);
    add(0.0, std::numeric_limits<double>::infinity(), layers.silicone_index);
  }

  // Snell's invariant k = n sin(theta) is the same in every layer; the horizontal travel
  // sum(t_i tan(theta_i)) is increasing in k, so Newton safeguarded by bisection finds it.
  const Eigen::Vector2d horizontal = (p_in_sensor - center).head<2>();
  const double rho = horizontal.norm();
  double n_min = std::numeric_limits<double>::infinity();
  for (const Layer& l : crossed) n_min = std::min(n_min, l.index);
  double lo = 0.0, hi = n_min, k = 0.0;
  if (rho > 0.0) {
    k = 0.5 * n_min;
    for (int it = 0; it < 200; ++it) {
      double travel = -rho, slope = 0.0;
      for (const Layer& l : crossed) {
        const double s = k / l.index;
        const double c = std::sqrt(1.0 - s * s);
        travel += l.thickness_mm * s / c;
        slope += l.thickness_mm / (l.index * c * c * c);
      }
          if (std::abs(travel) < 1e-13 * (1.0 + rho) || hi - lo < 1e-16) break;
      if (travel > 0.0) hi = k; else lo = k;
      k -= travel / slope;
      if (!(k > lo && k < hi)) k = 0.5 * (lo + hi);
    }
  }
  // Direction of the ray at the virtual camera, in air (index 1).
  const double n0 = crossed.front().index;
  const double s0 = k / n0;
  Eigen::Vector3d dir(0, 0, std::sqrt(1.0 - s0 * s0));
  if (rho > 0.0) dir.head<2>() = s0 * horizontal / rho;
  const Eigen::Vector3d d_in_vcam = sensor_from_vcam.linear().transpose() * dir;
  if (d_in_vcam.z() <= 1e-9) return std::nullopt;
  return intrinsics.Project(d_in_vcam);
}

}  // namespace tac3d
