#include "tac3d/geometry/geometry.h"

#include <algorithm>
#include <cmath>

namespace tac3d {

Plane Plane::FromPointNormal(const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = normal.normalized();
  return Plane{n, n.dot(point)};
}

Eigen::Vector3d Plane::Reflect(const Eigen::Vector3d& p) const {
  return p - 2.0 * SignedDistance(p) * normal;
}

Eigen::Affine3d Plane::ReflectionTransform() const {
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.linear() = Eigen::Matrix3d::Identity() - 2.0 * normal * normal.transpose();
  t.translation() = 2.0 * offset * normal;
  return t;
}

std::optional<double> IntersectRayPlane(const Ray& ray, const Plane& plane, double min_t) {
  const double denom = plane.normal.dot(ray.direction);
  if (std::abs(denom) < 1e-15) return std::nullopt;
  const double t = -plane.SignedDistance(ray.origin) / denom;
  if (t < min_t) return std::nullopt;
  return t;
}

Eigen::Vector3d ReflectDirection(const Eigen::Vector3d& direction, const Eigen::Vector3d& normal) {
  return direction - 2.0 * direction.dot(normal) * normal;
}

std::optional<Eigen::Vector3d> RefractDirection(const Eigen::Vector3d& direction,
                                                const Eigen::Vector3d& normal,
                                                double n1,
                                                double n2) {
  // Orient the normal against the incoming ray.
  Eigen::Vector3d n = normal;
  double cos_i = -n.dot(direction);
  if (cos_i < 0.0) {
    n = -n;
    cos_i = -cos_i;
  }
  const double eta = n1 / n2;
  const double sin2_t = eta * eta * (1.0 - cos_i * cos_i);
  if (sin2_t > 1.0) return std::nullopt;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  return (eta * direction + (eta * cos_i - cos_t) * n).normalized();
}

bool Rectangle3::Contains(const Eigen::Vector3d& p, double tolerance) const {
  const Eigen::Vector3d r = p - center;
  return std::abs(r.dot(u_axis)) <= half_u + tolerance &&
         std::abs(r.dot(v_axis)) <= half_v + tolerance;
}

std::optional<double> Rectangle3::Intersect(const Ray& ray, double min_t) const {
  const auto t = IntersectRayPlane(ray, plane(), min_t);
  if (!t || !Contains(ray.At(*t))) return std::nullopt;
  return t;
}

double RotationDefect(const Eigen::Matrix3d& r) {
  return std::max((r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(),
                  std::abs(r.determinant() - 1.0));
}

double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::Matrix3d r = a.transpose() * b;
  const double c = std::clamp((r.trace() - 1.0) / 2.0, -1.0, 1.0);
  return RadToDeg(std::acos(c));
}

Rigid3 InterpolatePose(const Rigid3& a, const Rigid3& b, double s) {
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  Rigid3 pose = Rigid3::Identity();
  pose.linear() = qa.slerp(s, qb).toRotationMatrix();
  pose.translation() = (1 - s) * a.translation() + s * b.translation();
  return pose;
}

}  // namespace tac3d
