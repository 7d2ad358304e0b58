#pragma once

#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tac3d {

/// A rigid transform target_from_source (rotation then translation), as in
/// `sensor_from_cam`.
using Rigid3 = Eigen::Isometry3d;

/// A half-line: origin + t * direction, t >= 0; direction is unit length.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;

  Eigen::Vector3d At(double t) const { return origin + t * direction; }
};

/// The plane {x : normal . x = offset}; normal is unit length.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;

  static Plane FromPointNormal(const Eigen::Vector3d& point, const Eigen::Vector3d& normal);
  double SignedDistance(const Eigen::Vector3d& p) const { return normal.dot(p) - offset; }
  /// The mirror image of a point.
  Eigen::Vector3d Reflect(const Eigen::Vector3d& p) const;
  /// The reflection as an affine map (linear part has determinant -1).
  Eigen::Affine3d ReflectionTransform() const;
};

/// Ray parameter t >= min_t where the ray meets the plane, if it does.
std::optional<double> IntersectRayPlane(const Ray& ray, const Plane& plane, double min_t = 0.0);

/// Direction of a ray after specular reflection on a surface with the given normal.
Eigen::Vector3d ReflectDirection(const Eigen::Vector3d& direction, const Eigen::Vector3d& normal);

/// Direction after refraction from index n1 into index n2 through a surface with the given
/// normal (either orientation), by Snell's law; nullopt on total internal reflection.
std::optional<Eigen::Vector3d> RefractDirection(const Eigen::Vector3d& direction,
                                                const Eigen::Vector3d& normal,
                                                double n1,
                                                double n2);

/// A planar rectangle: centre + s * u_axis + t * v_axis, |s| <= half_u, |t| <= half_v, with
/// orthonormal axes; its normal is u_axis x v_axis.
struct Rectangle3 {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d u_axis = Eigen::Vector3d::UnitX();
  Eigen::Vector3d v_axis = Eigen::Vector3d::UnitY();
  double half_u = 1.0;
  double half_v = 1.0;

  Eigen::Vector3d normal() const { return u_axis.cross(v_axis); }
  Plane plane() const { return Plane::FromPointNormal(center, normal()); }
  /// True if p (assumed on the plane) lies inside, with a tolerance in mm.
  bool Contains(const Eigen::Vector3d& p, double tolerance = 0.0) const;
  /// Ray parameter where the ray hits the rectangle, if it does.
  std::optional<double> Intersect(const Ray& ray, double min_t = 0.0) const;
};

/// How far a matrix is from a rotation: the larger of max|R R^T - I| and |det R - 1| (0 for one).
double RotationDefect(const Eigen::Matrix3d& r);

/// Rotation between two orientations in degrees.
double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

/// The pose a fraction s of the way from a to b: translation linear, rotation by slerp (the
/// shorter arc). s = 0 gives a, s = 1 gives b; s outside [0, 1] extrapolates.
/// @pre a and b are rigid (orthonormal rotation parts).
Rigid3 InterpolatePose(const Rigid3& a, const Rigid3& b, double s);

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double DegToRad(double deg) { return deg * kPi / 180.0; }
inline constexpr double RadToDeg(double rad) { return rad * 180.0 / kPi; }

}  // namespace tac3d
