#include "tac3d/design/light_path_design.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string_view>

#include <Eigen/LU>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

using Vec2 = Eigen::Vector2d;

double Cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

Vec2 Direction(double angle) { return {std::cos(angle), std::sin(angle)}; }

// Reflects a direction on a line with unit tangent t.
Vec2 ReflectOnLine(const Vec2& d, const Vec2& t) { return 2.0 * d.dot(t) * t - d; }

// Mirror image of a point across the line through p with unit tangent t.
Vec2 MirrorPoint(const Vec2& x, const Vec2& p, const Vec2& t) {
  const Vec2 r = x - p;
  return p + 2.0 * r.dot(t) * t - r;
}

// Where the ray from `origin` along `d` meets the line through `p` with tangent `t`.
std::optional<double> RayLineParameter(const Vec2& origin, const Vec2& d, const Vec2& p,
                                       const Vec2& t) {
  const double denom = Cross(t, d);
  if (std::abs(denom) < 1e-12) return std::nullopt;
  return Cross(t, p - origin) / denom;
}

// True if the open segments [a, b] and [c, e] cross (touching within `tolerance` of an
// end does not count).
bool SegmentsCross(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& e,
                   double tolerance = 1e-7) {
  const Vec2 r = b - a, s = e - c;
  const double denom = Cross(r, s);
  if (std::abs(denom) < 1e-15) return false;
  const double t = Cross(c - a, s) / denom;
  const double u = Cross(c - a, r) / denom;
  const double ta = tolerance / r.norm(), tc = tolerance / s.norm();
  return t > ta && t < 1.0 - ta && u > tc && u < 1.0 - tc;
}

// The forward model: every point of the light path for given unknowns, and the residuals.
struct Geometry {
  const LightPathDesignOptions& o;

  std::optional<LightPathRoot> Evaluate(const Eigen::Vector4d& x) const {
    LightPathRoot r;
    r.unknowns = x;
    const double zb = x(0);
    const Vec2 t2 = Direction(x(1));
    const Vec2 n1 = Direction(x(2));
    const Vec2 t1(-n1.y(), n1.x());
    const Vec2 p1 = x(3) * n1;  // a point of mirror 1's line
    r.camera = {0.0, -o.h_mm};
    r.center = {0.0, 0.0};
    r.a0 = {-0.5 * o.l_mm, 0.0};
    r.b0 = {0.5 * o.l_mm, 0.0};
    r.b2 = {0.0, zb};

    // B ray: along the axis into O, so leaving B2 straight down.
    const Vec2 d_b2 = ReflectOnLine({0.0, 1.0}, t2);
    const auto s_b = RayLineParameter(r.b2, d_b2, p1, t1);
    if (!s_b) return std::nullopt;
    r.b1 = r.b2 + *s_b * d_b2;
    const Vec2 d_b1 = ReflectOnLine(d_b2, t1);

    // A ray: enters O phi/2 off the axis.
    const double half = 0.5 * DegToRad(o.fov_deg);
    const Vec2 d_o(-std::sin(half), std::cos(half));
    const auto t_a = RayLineParameter(r.camera, d_o, r.b2, t2);
    if (!t_a) return std::nullopt;
    r.a2 = r.camera + *t_a * d_o;
    const Vec2 d_a2 = ReflectOnLine(d_o, t2);
    const auto s_a = RayLineParameter(r.a2, d_a2, p1, t1);
    if (!s_a) return std::nullopt;
    r.a1 = r.a2 + *s_a * d_a2;
    const Vec2 d_a1 = ReflectOnLine(d_a2, t1);

    const Vec2 to_b0 = r.b0 - r.b1, to_a0 = r.a0 - r.a1;
    const Vec2 b0_to_b1 = r.b1 - r.b0, b0_to_a2 = r.a2 - r.b0;
    if (to_b0.norm() < 1e-9 || to_a0.norm() < 1e-9 || b0_to_a2.norm() < 1e-9) return std::nullopt;
    // Residuals as sines of angles, so they are scale-free.
    r.residuals(0) = Cross(d_b1, to_b0) / to_b0.norm();
    r.residuals(1) = Cross(d_a1, to_a0) / to_a0.norm();
    r.residuals(2) = Cross(b0_to_b1, b0_to_a2) / (b0_to_b1.norm() * b0_to_a2.norm());
    r.virtual_camera = MirrorPoint(MirrorPoint(r.camera, r.b2, t2), p1, t1);
    const Vec2 v = r.virtual_camera - r.center;
    r.residuals(3) = (v.x() * v.x() - v.y() * v.y()) / v.squaredNorm();  // 0 at 45 deg
    const Vec2 w = MirrorX(r.virtual_camera) - r.center;
    r.parallax_deg = RadToDeg(std::acos(std::clamp(v.dot(w) / (v.norm() * w.norm()), -1.0, 1.0)));
    return r;
  }

  // The ways a root can be physically impossible.
  void Judge(LightPathRoot& r) const {
    auto reject = [&r](std::string_view why) { r.rejections.emplace_back(why); };
    const double zb = r.b2.y();
    if (!(zb > -o.h_mm && zb < 0.0)) {
      reject(zb <= -o.h_mm ? "mirror 2 is behind the camera" : "mirror 2 is above the elastic body's face");
    }
    // Light must travel forwards along every leg.
    const Vec2 d_b2 = r.b1 - r.b2, d_a2 = r.a1 - r.a2;
    if (r.b2.y() - r.camera.y() <= 0.0 || (r.a2 - r.camera).y() <= 0.0) {
      reject("mirror 2 is behind the camera");
    }
    const Vec2 t2 = Direction(r.unknowns(1));
    const Vec2 n1 = Direction(r.unknowns(2));
    if (d_b2.dot(ReflectOnLine({0.0, 1.0}, t2)) <= 0.0 || d_a2.dot(ReflectOnLine((r.a2 - r.camera).normalized(), t2)) <= 0.0) {
      reject("mirror 1 is behind mirror 2 (the light would travel backwards)");
    }
    const Vec2 t1(-n1.y(), n1.x());
    if ((r.b0 - r.b1).dot(ReflectOnLine(d_b2, t1)) <= 0.0 || (r.a0 - r.a1).dot(ReflectOnLine(d_a2, t1)) <= 0.0) {
      reject("the fingertip is behind mirror 1 (the light would travel backwards)");
    }
    // Both beams must strike the same (reflective) face of each mirror.
    if (n1.dot(r.a2 - r.a1) * n1.dot(r.b2 - r.b1) <= 0.0) {
      reject("the two beams strike opposite faces of mirror 1");
    }
    for (const auto& [name, p] : {std::pair{"A1", r.a1}, std::pair{"B1", r.b1}, std::pair{"A2", r.a2}}) {
      if (p.y() <= -o.h_mm) reject(fmt::format("{} is behind the camera", name));
      if (p.y() >= o.d_mm) reject(fmt::format("{} is above the fingertip", name));
      if (p.y() >= 0.0 && std::abs(p.x()) <= 0.5 * o.l_mm) {
        reject(fmt::format("{} is inside the elastic body", name));
      }
      if (p.x() >= 0.0) reject(fmt::format("{} is on the wrong side of the axis", name));
    }
    if (!(r.virtual_camera.x() < 0.0 && r.virtual_camera.y() < 0.0)) {
      reject("the virtual camera does not look at the fingertip from below its own side");
    }
    // Nothing may cut a beam, and mirrors may not cross. Mirrors 3 and 4 are the
    // images of 2 and 1 across the axis.
    const std::array<std::pair<Vec2, Vec2>, 4> mirrors = {
        std::pair{r.a1, r.b1}, std::pair{r.b2, r.a2}, std::pair{MirrorX(r.b2), MirrorX(r.a2)},
        std::pair{MirrorX(r.a1), MirrorX(r.b1)}};
    const std::array<std::pair<Vec2, Vec2>, 6> legs = {
        std::pair{r.camera, r.a2}, std::pair{r.a2, r.a1}, std::pair{r.a1, r.a0},
        std::pair{r.camera, r.b2}, std::pair{r.b2, r.b1}, std::pair{r.b1, r.b0}};
    for (size_t i = 0; i < legs.size(); ++i) {
      for (size_t m = 0; m < mirrors.size(); ++m) {
        if (SegmentsCross(legs[i].first, legs[i].second, mirrors[m].first, mirrors[m].second)) {
          reject(fmt::format("the {} beam passes through mirror {}", i < 3 ? "A" : "B", m + 1));
        }
      }
    }
    if (SegmentsCross(mirrors[0].first, mirrors[0].second, mirrors[1].first, mirrors[1].second) ||
        SegmentsCross(mirrors[0].first, mirrors[0].second, mirrors[3].first, mirrors[3].second)) {
      reject("mirror 1 crosses another mirror");
    }
    // Keep the list short and unique.
    std::sort(r.rejections.begin(), r.rejections.end());
    r.rejections.erase(std::unique(r.rejections.begin(), r.rejections.end()), r.rejections.end());
  }
};

// Damped Newton with a forward-difference Jacobian.
std::optional<LightPathRoot> Newton(const Geometry& g, Eigen::Vector4d x) {
  auto value = g.Evaluate(x);
  if (!value) return std::nullopt;
  for (int it = 0; it < 100; ++it) {
    if (value->max_residual() < 1e-14) break;
    Eigen::Matrix4d jacobian;
    for (int k = 0; k < 4; ++k) {
      const double step = 1e-7 * std::max(1.0, std::abs(x(k)));
      Eigen::Vector4d xp = x, xm = x;
      xp(k) += step;
      xm(k) -= step;
      const auto fp = g.Evaluate(xp), fm = g.Evaluate(xm);
      if (!fp || !fm) return std::nullopt;
      jacobian.col(k) = (fp->residuals - fm->residuals) / (2.0 * step);
    }
    const Eigen::FullPivLU<Eigen::Matrix4d> lu(jacobian);
    if (lu.rank() < 4) return std::nullopt;
    const Eigen::Vector4d delta = lu.solve(value->residuals);
    double lambda = 1.0;
    bool improved = false;
    for (int ls = 0; ls < 30; ++ls, lambda *= 0.5) {
      const auto trial = g.Evaluate(x - lambda * delta);
      if (trial && trial->residuals.norm() < value->residuals.norm()) {
        x -= lambda * delta;
        value = trial;
        improved = true;
        break;
      }
    }
    if (!improved) break;
  }
  if (value->max_residual() > 1e-11) return std::nullopt;
  return value;
}

// One representation per root: angles of lines are defined modulo pi.
Eigen::Vector4d Canonical(Eigen::Vector4d x) {
  x(1) = std::fmod(std::fmod(x(1), kPi) + kPi, kPi);
  double a1 = std::fmod(std::fmod(x(2), 2 * kPi) + 2 * kPi, 2 * kPi);
  if (a1 >= kPi) {
    a1 -= kPi;
    x(3) = -x(3);
  }
  x(2) = a1;
  return x;
}

Rectangle3 MakeMirror(const Vec2& end_a, const Vec2& end_b, const Vec2& reflective_side_point,
                      double margin_fraction, double half_height) {
  Rectangle3 r;
  const Vec2 mid = 0.5 * (end_a + end_b);
  const Vec2 along = (end_b - end_a).normalized();
  r.center = {mid.x(), 0.0, mid.y()};
  r.u_axis = {along.x(), 0.0, along.y()};
  r.v_axis = Eigen::Vector3d::UnitY();
  r.half_u = 0.5 * (end_b - end_a).norm() * (1.0 + 2.0 * margin_fraction);
  r.half_v = half_height;
  const Eigen::Vector3d side(reflective_side_point.x(), 0.0, reflective_side_point.y());
  if (r.normal().dot(side - r.center) < 0.0) r.v_axis = -r.v_axis;
  return r;
}

Rectangle3 MirrorAcrossYZ(const Rectangle3& m) {
  Rectangle3 r = m;
  r.center.x() = -m.center.x();
  r.u_axis.x() = -m.u_axis.x();
  // Mirroring flips handedness: flip v to keep the reflective side mirrored too.
  r.v_axis = -m.v_axis;
  return r;
}

}  // namespace

void LightPathDesignOptions::Validate() const {
  const OptionCheck require("light path design");
  const std::string length_bound = fmt::format("> 0 and <= {} mm", SensorLimits::kMaxLengthMm);
  for (const auto& [field, value] : {std::pair{"h_mm", h_mm}, {"l_mm", l_mm}, {"d_mm", d_mm}}) {
    require(value > 0 && value <= SensorLimits::kMaxLengthMm, field, length_bound.c_str(), value);
  }
  require(fov_deg > 0 && fov_deg < 180, "fov_deg", "in (0, 180) deg", fov_deg);
  require(starts_per_axis >= 2 && starts_per_axis <= 40, "starts_per_axis", "in [2, 40]",
          starts_per_axis);
  require(outer_mirror_margin >= 0 && outer_mirror_margin < 0.5, "outer_mirror_margin",
          "in [0, 0.5)", outer_mirror_margin);
}

LightPathDesign DesignLightPath(const LightPathDesignOptions& options, const SensorConfig& base) {
  options.Validate();
  const auto start_time = std::chrono::steady_clock::now();
  const Geometry geometry{options};
  LightPathDesign design;

  const int n = options.starts_per_axis;
  const double reach = 2.0 * (options.h_mm + options.l_mm);
  std::vector<Eigen::Vector4d> found;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < n; ++k) {
        for (int m = 0; m < n; ++m) {
          const Eigen::Vector4d start(-1.5 * options.h_mm + 2.0 * options.h_mm * (i + 0.5) / n,
                                      kPi * (j + 0.5) / n, kPi * (k + 0.5) / n,
                                      -reach + 2.0 * reach * (m + 0.5) / n);
          ++design.summary.starts;
          auto root = Newton(geometry, start);
          if (!root) continue;
          ++design.summary.converged;
          const Eigen::Vector4d key = Canonical(root->unknowns);
          const bool seen = std::any_of(found.begin(), found.end(), [&](const Eigen::Vector4d& f) {
            return (f - key).cwiseAbs().maxCoeff() < 1e-6;
          });
          if (seen) continue;
          found.push_back(key);
          geometry.Judge(*root);
          design.roots.push_back(*root);
        }
      }
    }
  }
  std::stable_sort(design.roots.begin(), design.roots.end(),
                   [](const LightPathRoot& a, const LightPathRoot& b) { return a.valid() && !b.valid(); });
  design.summary.distinct_roots = static_cast<int>(design.roots.size());
  design.summary.valid_roots = static_cast<int>(
      std::count_if(design.roots.begin(), design.roots.end(), [](const auto& r) { return r.valid(); }));

  if (design.summary.valid_roots > 0) {
    design.chosen = 0;
    const LightPathRoot& r = design.roots.front();
    SensorConfig config = base;
    config.light_path = {options.h_mm, options.l_mm, options.d_mm, options.fov_deg};
    config.camera.horizontal_fov_deg = options.fov_deg;
    config.camera.intrinsics = CameraIntrinsics::FromFieldOfView(
        base.camera.intrinsics.width, base.camera.intrinsics.height, options.fov_deg);
    config.camera.sensor_from_cam = Rigid3(Eigen::Translation3d(0, 0, -options.h_mm));

    // Heights first from unbounded mirrors, then each mirror made tall enough for every
    // ray of its image half (top and bottom rows, all columns).
    Rectangle3 inner = MakeMirror(r.b2, r.a2, r.camera, 0.0, 1e6);
    Rectangle3 outer = MakeMirror(r.a1, r.b1, r.a2, options.outer_mirror_margin, 1e6);
    double inner_half = 0.0, outer_half = 0.0;
    const CameraIntrinsics& cam = config.camera.intrinsics;
    const Ray axis_ray{config.camera.sensor_from_cam.translation(), Eigen::Vector3d::UnitZ()};
    for (int row : {0, cam.height - 1}) {
      for (int col = 0; col < cam.width / 2; ++col) {
        const Ray ray{axis_ray.origin, config.camera.sensor_from_cam.linear() *
                                           cam.Unproject({static_cast<double>(col), static_cast<double>(row)})};
        const auto t_inner = IntersectRayPlane(ray, inner.plane());
        if (!t_inner) continue;
        const Eigen::Vector3d hit_inner = ray.At(*t_inner);
        const Ray reflected{hit_inner, ReflectDirection(ray.direction, inner.normal())};
        const auto t_outer = IntersectRayPlane(reflected, outer.plane());
        if (!t_outer) continue;
        inner_half = std::max(inner_half, std::abs(hit_inner.y()));
        outer_half = std::max(outer_half, std::abs(reflected.At(*t_outer).y()));
      }
    }
    // 5% plus half a millimetre of slack for assembly tolerances.
    inner.half_v = 1.05 * inner_half + 0.5;
    outer.half_v = 1.05 * outer_half + 0.5;
    config.mirrors = {MirrorConfig{"mirror_1", outer}, MirrorConfig{"mirror_2", inner},
                      MirrorConfig{"mirror_3", MirrorAcrossYZ(inner)},
                      MirrorConfig{"mirror_4", MirrorAcrossYZ(outer)}};
    const OpticalLayout layout = config.MakeOpticalLayout();
    config.virtual_cameras.clear();
    for (ImageHalf half : kImageHalves) {
      VirtualCameraConfig v;
      v.half = half;
      v.name = half == ImageHalf::kLeft ? "vcam_left" : "vcam_right";
      v.sensor_from_vcam = layout.SensorFromVirtualCamera(half);
      v.intrinsics = cam;
      const int split = static_cast<int>(std::ceil(cam.cx));
      v.column_begin = half == ImageHalf::kLeft ? 0 : split;
      v.column_end = half == ImageHalf::kLeft ? split : cam.width;
      config.virtual_cameras.push_back(v);
    }
    config.Validate();
    design.config = config;
  }
  design.summary.seconds = SecondsSince(start_time);
  return design;
}

LightPathDesignOptions DesignOptionsOf(const SensorConfig& sensor) {
  LightPathDesignOptions options;
  options.h_mm = sensor.light_path.h_mm;
  options.l_mm = sensor.light_path.l_mm;
  options.d_mm = sensor.light_path.d_mm;
  options.fov_deg = sensor.light_path.fov_deg;
  return options;
}

}  // namespace tac3d
