#include "tac3d/simulation/gap.h"

#include <gtest/gtest.h>

#include <cmath>

namespace tac3d::simulation {
namespace {

const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

SceneObject Shape(SceneObject::Shape shape) {
  SceneObject o;
  o.shape = shape;
  return o;
}

TEST(IntersectAnalyticObject, SphereMatchesTheClosedForm) {
  SceneObject s = Shape(SceneObject::Shape::kSphere);
  s.radius_mm = 5.0;
  // A vertical line at x = 3 from z = -10 enters at z = -sqrt(25 - 9) = -4.
  const auto hit = IntersectAnalyticObject(s, {3, 0, -10}, kUp);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t_mm, 6.0, 1e-12);
  EXPECT_NEAR(hit->p_object.z(), -4.0, 1e-12);
  // Inside: negative entry; beyond the radius or behind the origin: nothing.
  EXPECT_NEAR(IntersectAnalyticObject(s, {0, 0, -4}, kUp)->t_mm, -1.0, 1e-12);
  EXPECT_FALSE(IntersectAnalyticObject(s, {5.1, 0, -10}, kUp));
  EXPECT_FALSE(IntersectAnalyticObject(s, {0, 0, 6}, kUp));
}

TEST(IntersectAnalyticObject, CylinderIsFiniteAndCapped) {
  SceneObject c = Shape(SceneObject::Shape::kCylinder);
  c.radius_mm = 10.0;
  c.length_mm = 20.0;
  // Axis along y: at x = 6 the surface is at z = -8.
  EXPECT_NEAR(IntersectAnalyticObject(c, {6, 5, -20}, kUp)->t_mm, 12.0, 1e-12);
  EXPECT_FALSE(IntersectAnalyticObject(c, {6, 10.5, -20}, kUp));  // beyond the cap
  // A line along the axis enters through the cap at y = -10.
  const auto along = IntersectAnalyticObject(c, {0, -15, 0}, Eigen::Vector3d::UnitY());
  ASSERT_TRUE(along);
  EXPECT_NEAR(along->t_mm, 5.0, 1e-12);
}

TEST(IntersectAnalyticObject, FlatPunchPinsAndBox) {
  SceneObject punch = Shape(SceneObject::Shape::kFlatPunch);
  punch.radius_mm = 2.0;
  EXPECT_NEAR(IntersectAnalyticObject(punch, {1.9, 0, -3}, kUp)->t_mm, 3.0, 1e-12);
  EXPECT_FALSE(IntersectAnalyticObject(punch, {2.1, 0, -3}, kUp));
  // A tilted line hits the face at z = 0 where it is inside the disc.
  const Eigen::Vector3d tilted = Eigen::Vector3d(1, 0, 1).normalized();
  EXPECT_NEAR(IntersectAnalyticObject(punch, {-1, 0, -1}, tilted)->t_mm, std::sqrt(2.0), 1e-12);

  SceneObject pins = Shape(SceneObject::Shape::kPins);
  pins.radius_mm = 0.5;
  pins.rows = 1;
  pins.cols = 2;
  pins.pitch_mm = 2.0;
  EXPECT_NEAR(IntersectAnalyticObject(pins, {1.2, 0, -1}, kUp)->t_mm, 1.0, 1e-12);
  EXPECT_NEAR(IntersectAnalyticObject(pins, {-0.8, 0.3, -1}, kUp)->t_mm, 1.0, 1e-12);
  EXPECT_FALSE(IntersectAnalyticObject(pins, {0, 0, -1}, kUp));  // between the pins

  SceneObject box = Shape(SceneObject::Shape::kBox);
  box.size_mm = {4, 6, 2};
  EXPECT_NEAR(IntersectAnalyticObject(box, {1.9, 2.9, -3}, kUp)->t_mm, 2.0, 1e-12);
  EXPECT_NEAR(IntersectAnalyticObject(box, {0, 0, 0.5}, kUp)->t_mm, -1.5, 1e-12);
  EXPECT_FALSE(IntersectAnalyticObject(box, {2.1, 0, -3}, kUp));
}

TEST(IntersectAnalyticObject, FlatPunchWithARoundedEdge) {
  SceneObject punch = Shape(SceneObject::Shape::kFlatPunch);
  punch.radius_mm = 3.0;
  punch.edge_radius_mm = 1.0;
  // Along the axis: the flat face inside rho = 2, the quarter circle about (rho, z) = (2, 1) in
  // the rim: at rho = 2.6 it is at z = 1 - sqrt(1 - 0.36) = 0.2.
  EXPECT_NEAR(IntersectAnalyticObject(punch, {1.9, 0, -3}, kUp)->t_mm, 3.0, 1e-12);
  EXPECT_NEAR(IntersectAnalyticObject(punch, {0, 2.6, -3}, kUp)->t_mm, 3.2, 1e-12);
  EXPECT_NEAR(IntersectAnalyticObject(punch, {2.9, 0, -3}, kUp)->p_object.z(), 1.0 - std::sqrt(1.0 - 0.81),
              1e-12);
  EXPECT_FALSE(IntersectAnalyticObject(punch, {3.05, 0, -3}, kUp));
  // A tilted line: the march agrees with the first sample inside the body (points within
  // 1 mm of the cylinder rho <= 2, z >= 1), found by stepping 1e-5 mm along the line.
  const auto inside = [](const Eigen::Vector3d& p) {
    const double rho = p.head<2>().norm();
    return p.z() >= 0.0 && rho <= 3.0 &&
           (rho <= 2.0 || p.z() >= 1.0 || std::hypot(rho - 2.0, p.z() - 1.0) <= 1.0);
  };
  for (const double x : {1.0, 2.5, 2.8, 3.3}) {
    SCOPED_TRACE(x);
    const Eigen::Vector3d origin(x, 0.2, -1.0), direction = Eigen::Vector3d(0.3, 0.1, 1).normalized();
    double first = -1.0;
    for (double t = 0.0; t < 4.0; t += 1e-5) {
      if (inside(origin + t * direction)) {
        first = t;
        break;
      }
    }
    const auto hit = IntersectAnalyticObject(punch, origin, direction);
    ASSERT_EQ(hit.has_value(), first >= 0.0);
    if (hit) {
      EXPECT_NEAR(hit->t_mm, first, 2e-5);
    }
  }
  // A sharp punch of the same radius is entered lower in the rim.
  punch.edge_radius_mm = 0.0;
  EXPECT_NEAR(IntersectAnalyticObject(punch, {0, 2.6, -3}, kUp)->t_mm, 3.0, 1e-12);
}

// A closed octahedron mesh against the same solid's closed form: |x| + |y| + |z| <= 1.
TEST(GapCaster, MeshZBufferMatchesTheSolid) {
  TriangleMesh octahedron;
  octahedron.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  // Counter-clockwise seen from outside.
  octahedron.triangles = {
      {0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  SceneObject mesh = Shape(SceneObject::Shape::kMesh);
  mesh.mesh = std::make_shared<IndexedMesh>(octahedron);
  mesh.world_from_object = Rigid3(Eigen::Translation3d(0, 0, 3));
  mesh.friction.default_mu = 0.7;
  const contact::SurfaceGrid grid{9, 9, 0.25, 0.25};
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < grid.num_nodes(); ++i) {
    const Eigen::Vector2d xy = grid.node_position_mm(i);
    points.emplace_back(xy.x(), xy.y(), 0.5);
  }
  const GapCaster caster({mesh}, grid, points, std::vector<bool>(grid.num_nodes(), true));
  const GapField field = caster.Cast(Rigid3::Identity());
  for (int i = 0; i < grid.num_nodes(); ++i) {
    const Eigen::Vector2d xy = grid.node_position_mm(i);
    const double l1 = std::abs(xy.x()) + std::abs(xy.y());
    if (l1 < 0.999) {
      // The lower face z = 3 - (1 - |x| - |y|), from z = 0.5.
      EXPECT_NEAR(field.gap_mm[i], 2.5 - (1.0 - l1), 1e-12) << i;
      EXPECT_EQ(field.friction_coefficient[i], 0.7);
      EXPECT_EQ(field.object[i], 0);
    } else if (l1 > 1.001) {
      EXPECT_TRUE(std::isinf(field.gap_mm[i])) << i;
      EXPECT_EQ(field.object[i], -1);
    }
  }
}

TEST(GapCaster, NearestObjectWinsAndThePoseMovesTheLines) {
  SceneObject near = Shape(SceneObject::Shape::kBox);
  near.size_mm = {10, 10, 2};
  near.world_from_object = Rigid3(Eigen::Translation3d(0, 0, 5));
  near.friction.default_mu = 0.3;
  SceneObject far = near;
  far.world_from_object = Rigid3(Eigen::Translation3d(0, 0, 8));
  far.friction.default_mu = 0.9;
  const contact::SurfaceGrid grid{3, 3, 1.0, 1.0};
  std::vector<Eigen::Vector3d> points(grid.num_nodes(), Eigen::Vector3d::Zero());
  const GapCaster caster({far, near}, grid, points, std::vector<bool>(grid.num_nodes(), true));
  const GapField field = caster.Cast(Rigid3(Eigen::Translation3d(0, 0, 1)));
  EXPECT_NEAR(field.gap_mm[4], 3.0, 1e-12);  // the near box's bottom z = 4, the line from z = 1
  EXPECT_EQ(field.object[4], 1);
  EXPECT_EQ(field.friction_coefficient[4], 0.3);
  // Turned upside down, the lines point away from both.
  const GapField away = caster.Cast(Rigid3(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX())));
  EXPECT_TRUE(std::isinf(away.gap_mm[4]));
}

}  // namespace
}  // namespace tac3d::simulation
