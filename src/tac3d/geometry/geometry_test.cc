#include "tac3d/geometry/geometry.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

TEST(Plane, ReflectionIsAnInvolutionWithNegativeDeterminant) {
  const Plane plane = Plane::FromPointNormal({1, 2, 3}, {0.3, -0.5, 0.8});
  const Eigen::Affine3d m = plane.ReflectionTransform();
  EXPECT_NEAR(m.linear().determinant(), -1.0, 1e-12);
  const Eigen::Vector3d p(-4, 5, 0.5);
  EXPECT_THAT((m * (m * p)).eval(), EigenNear(p, 1e-12));
  EXPECT_THAT((m * p).eval(), EigenNear(plane.Reflect(p), 1e-12));
  // The mirror image is as far behind the plane as the point is in front.
  EXPECT_NEAR(plane.SignedDistance(plane.Reflect(p)), -plane.SignedDistance(p), 1e-12);
}

TEST(Plane, TwoReflectionsAreARigidMotion) {
  const Plane a = Plane::FromPointNormal({0, 0, 1}, {1, 0, 1});
  const Plane b = Plane::FromPointNormal({2, 0, 0}, {-1, 0, 3});
  const Eigen::Affine3d m = a.ReflectionTransform() * b.ReflectionTransform();
  EXPECT_NEAR(m.linear().determinant(), 1.0, 1e-12);
  EXPECT_THAT((m.linear() * m.linear().transpose()).eval(),
              EigenNear(Eigen::Matrix3d::Identity(), 1e-12));
}

TEST(Ray, IntersectPlane) {
  const Ray ray{{0, 0, -5}, Eigen::Vector3d(0, 0.6, 0.8)};
  const Plane plane = Plane::FromPointNormal({0, 0, 3}, {0, 0, 1});
  const auto t = IntersectRayPlane(ray, plane);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 10.0, 1e-12);
  EXPECT_THAT(ray.At(*t), EigenNear(Eigen::Vector3d(0, 6, 3), 1e-12));
  // Behind the origin or parallel: no hit.
  EXPECT_FALSE(IntersectRayPlane(Ray{{0, 0, 5}, {0, 0.6, 0.8}}, plane).has_value());
  EXPECT_FALSE(IntersectRayPlane(Ray{{0, 0, 0}, {1, 0, 0}}, plane).has_value());
}

TEST(Refraction, FollowsSnellsLaw) {
  const Eigen::Vector3d normal(0, 0, 1);
  const double incidence = DegToRad(35.0);
  const Eigen::Vector3d d(std::sin(incidence), 0, std::cos(incidence));
  const auto t = RefractDirection(d, normal, 1.0, 1.52);
  ASSERT_TRUE(t.has_value());
  const double sin_t = std::hypot((*t)(0), (*t)(1));
  EXPECT_NEAR(1.0 * std::sin(incidence), 1.52 * sin_t, 1e-12);
  EXPECT_GT((*t)(2), 0.0);
  // The normal's orientation does not matter.
  EXPECT_THAT(RefractDirection(d, -normal, 1.0, 1.52).value(), EigenNear(*t, 1e-15));
  // Back out through the same interface restores the direction.
  EXPECT_THAT(RefractDirection(*t, normal, 1.52, 1.0).value(), EigenNear(d, 1e-12));
}

TEST(Refraction, TotalInternalReflection) {
  const double incidence = DegToRad(60.0);
  const Eigen::Vector3d d(std::sin(incidence), 0, std::cos(incidence));
  EXPECT_FALSE(RefractDirection(d, {0, 0, 1}, 1.52, 1.0).has_value());
}

TEST(Rectangle3, IntersectInsideAndOutside) {
  Rectangle3 r;
  r.center = {0, 0, 10};
  r.half_u = 2;
  r.half_v = 1;
  EXPECT_TRUE(r.Intersect(Ray{{1.9, 0.9, 0}, {0, 0, 1}}).has_value());
  EXPECT_FALSE(r.Intersect(Ray{{2.1, 0, 0}, {0, 0, 1}}).has_value());
  EXPECT_FALSE(r.Intersect(Ray{{0, 1.1, 0}, {0, 0, 1}}).has_value());
}

TEST(Rotation, AngleBetween) {
  const Eigen::Matrix3d a = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d b =
      a * Eigen::AngleAxisd(DegToRad(7.0), Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  EXPECT_NEAR(RotationAngleDeg(a, b), 7.0, 1e-9);
}

TEST(InterpolatePose, EndsAndSlerpMidpoint) {
  Rigid3 a = Rigid3::Identity();
  a.translation() = Eigen::Vector3d(1, 2, 3);
  Rigid3 b = Rigid3::Identity();
  b.linear() = Eigen::AngleAxisd(DegToRad(90), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  b.translation() = Eigen::Vector3d(3, 6, -1);
  EXPECT_THAT(InterpolatePose(a, b, 0.0).matrix(), EigenNear(a.matrix(), 1e-12));
  EXPECT_THAT(InterpolatePose(a, b, 1.0).matrix(), EigenNear(b.matrix(), 1e-12));
  // Halfway: 45 deg about z, translation the midpoint.
  const Rigid3 mid = InterpolatePose(a, b, 0.5);
  const Eigen::Matrix3d r45 = Eigen::AngleAxisd(DegToRad(45), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_THAT(mid.linear().eval(), EigenNear(r45, 1e-12));
  EXPECT_THAT(mid.translation().eval(), EigenNear(Eigen::Vector3d(2, 4, 1), 1e-12));
}

TEST(InterpolatePose, TakesTheShorterArc) {
  // 350 deg about x is -10 deg: the midpoint is -5 deg, not 175 deg.
  Rigid3 b = Rigid3::Identity();
  b.linear() = Eigen::AngleAxisd(DegToRad(350), Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Rigid3 mid = InterpolatePose(Rigid3::Identity(), b, 0.5);
  EXPECT_NEAR(RotationAngleDeg(Eigen::Matrix3d::Identity(), mid.linear()), 5.0, 1e-9);
}

}  // namespace
}  // namespace tac3d
