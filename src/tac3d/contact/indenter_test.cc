#include "tac3d/contact/indenter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Indenter, SphereIsExactAndEndsAtItsEquator) {
  const Indenter sphere = Indenter::Sphere(10.0);
  EXPECT_DOUBLE_EQ(sphere.Separation({0.0, 0.0}), 0.0);
  EXPECT_NEAR(sphere.Separation({3.0, 4.0}), 10.0 - std::sqrt(75.0), 1e-14);
  EXPECT_EQ(sphere.Separation({10.0, 0.5}), kInf);
}

TEST(Indenter, CylinderDependsOnlyOnTheDistanceFromItsAxis) {
  const double angle = 0.3;
  const Indenter cylinder = Indenter::Cylinder(5.0, angle);
  const Eigen::Vector2d along(std::cos(angle), std::sin(angle));
  const Eigen::Vector2d across(-std::sin(angle), std::cos(angle));
  EXPECT_NEAR(cylinder.Separation(7.0 * along), 0.0, 1e-15);
  EXPECT_NEAR(cylinder.Separation(2.0 * across - 3.0 * along), 5.0 - std::sqrt(21.0), 1e-14);
  EXPECT_EQ(cylinder.Separation(6.0 * across), kInf);
}

TEST(Indenter, PunchAndPinsAreFlatFacesWithNothingAround) {
  const Indenter punch = Indenter::FlatPunch(1.0);
  EXPECT_EQ(punch.Separation({0.7, 0.7}), 0.0);
  EXPECT_EQ(punch.Separation({0.8, 0.8}), kInf);
  const Indenter pins = Indenter::Pins({{{-1.27, 0.0}, 0.5, 0.0}, {{1.27, 0.0}, 0.5, 0.02}});
  EXPECT_EQ(pins.Separation({-1.0, 0.0}), 0.0);
  EXPECT_EQ(pins.Separation({1.5, 0.0}), 0.02);
  EXPECT_EQ(pins.Separation({0.0, 0.0}), kInf);
}

TEST(Indenter, PlaneAndHeightFunction) {
  EXPECT_EQ(Indenter::Plane().Separation({3.0, -2.0}), 0.0);
  const Indenter ramp =
      Indenter::HeightFunction([](double x, double y) { return 0.1 * x + y * y; });
  EXPECT_DOUBLE_EQ(ramp.Separation({2.0, 3.0}), 9.2);
}

TEST(Indenter, CalcGapPlacesTheOriginOnTheGrid) {
  const SurfaceGrid grid{5, 3, 0.5, 0.5};
  const Indenter sphere = Indenter::Sphere(2.0);
  const Eigen::VectorXd gap = sphere.CalcGap(grid, {0.5, 0.0});
  ASSERT_EQ(gap.size(), 15);
  EXPECT_EQ(gap[8], 0.0);  // node (3, 1) at (0.5, 0)
  EXPECT_NEAR(gap[7], sphere.Separation({-0.5, 0.0}), 1e-15);
  EXPECT_NEAR(gap[0], sphere.Separation({-1.5, -0.5}), 1e-15);
}

TEST(Indenter, RejectsBadShapesAndBrokenProfiles) {
  EXPECT_THROW(Indenter::Sphere(0.0), Error);
  EXPECT_THROW(Indenter::Cylinder(-1.0, 0.0), Error);
  EXPECT_THROW(Indenter::Cylinder(1.0, NAN), Error);
  EXPECT_THROW(Indenter::FlatPunch(NAN), Error);
  EXPECT_THROW(Indenter::Pins({}), Error);
  EXPECT_THROW(Indenter::Pins({{{0.0, 0.0}, 1.0, -0.1}}), Error);
  EXPECT_THROW(Indenter::HeightFunction(nullptr), Error);
  const Indenter broken =
      Indenter::HeightFunction([](double x, double) { return x > 0 ? NAN : 0.0; });
  EXPECT_THROW(broken.CalcGap(SurfaceGrid{3, 3, 1.0, 1.0}, Eigen::Vector2d::Zero()), Error);
}

}  // namespace
}  // namespace tac3d::contact
