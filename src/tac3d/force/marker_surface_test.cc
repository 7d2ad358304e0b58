#include "tac3d/force/marker_surface.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr int kRows = 8, kCols = 7;
constexpr double kPitch = 1.27;

// Grid points at (x, y) = pitch (col - (cols-1)/2, row - (rows-1)/2), z = height(x, y).
template <typename Height>
std::vector<Eigen::Vector3d> Grid(Height height, double x_sign = 1.0) {
  std::vector<Eigen::Vector3d> points;
  for (int row = 0; row < kRows; ++row) {
    for (int col = 0; col < kCols; ++col) {
      const double x = x_sign * kPitch * (col - 0.5 * (kCols - 1));
      const double y = kPitch * (row - 0.5 * (kRows - 1));
      points.emplace_back(x, y, height(x, y));
    }
  }
  return points;
}

// The displacement field taking `from` to `to`, paper ordering.
Eigen::VectorXd Displacements(const std::vector<Eigen::Vector3d>& from,
                              const std::vector<Eigen::Vector3d>& to) {
  const int n = static_cast<int>(from.size());
  Eigen::VectorXd d(3 * n);
  for (int i = 0; i < n; ++i) {
    for (int axis = 0; axis < 3; ++axis) d(axis * n + i) = to[i](axis) - from[i](axis);
  }
  return d;
}

const auto kFlat = [](double, double) { return 8.0; };

TEST(MarkerSurface, SphereNormalsAreRadial) {
  const double radius = 45.0;
  const auto sphere = [&](double x, double y) { return std::sqrt(radius * radius - x * x - y * y); };
  const std::vector<Eigen::Vector3d> rest = Grid(sphere);
  const MarkerSurface surface(kRows, kCols, rest);
  for (int row = 0; row < kRows; ++row) {
    for (int col = 0; col < kCols; ++col) {
      const int i = row * kCols + col;
      const Eigen::Vector3d radial = rest[i].normalized();
      const double angle = std::acos(std::min(1.0, surface.rest_normals().col(i).dot(radial)));
      // Central differences are second order, (pitch / R)^2 ~ 1e-3; a one-sided difference at
      // the border tilts its tangent by pitch / (2 R) = 0.014 rad, at a corner both do.
      const bool border = row == 0 || col == 0 || row == kRows - 1 || col == kCols - 1;
      EXPECT_LT(angle, border ? std::sqrt(2.0) * kPitch / (2 * radius) + 1e-3 : 1e-3)
          << row << " " << col;
    }
  }
}

TEST(MarkerSurface, TiltedPlaneIsExactWithInvalidMarkers) {
  const std::vector<Eigen::Vector3d> rest = Grid(kFlat);
  const MarkerSurface surface(kRows, kCols, rest);
  // Tilting the plane to z = 8 + 0.3 x - 0.2 y: normal (-0.3, 0.2, 1) normalised, everywhere.
  const Eigen::VectorXd d =
      Displacements(rest, Grid([](double x, double y) { return 8.0 + 0.3 * x - 0.2 * y; }));
  std::vector<bool> valid(kRows * kCols, true);
  valid[3 * kCols + 3] = valid[3 * kCols + 4] = valid[0] = false;
  int num_rest = -1;
  const Eigen::Matrix3Xd normals = surface.CalcNormals(d, valid, &num_rest);
  EXPECT_EQ(num_rest, 0);
  const Eigen::Vector3d expected = Eigen::Vector3d(-0.3, 0.2, 1.0).normalized();
  for (int i = 0; i < kRows * kCols; ++i) {
    EXPECT_THAT(normals.col(i).eval(), EigenNear(expected, 1e-12)) << i;
  }
}

TEST(MarkerSurface, IsolatedMarkerFallsBackToItsRestNormal) {
  const std::vector<Eigen::Vector3d> rest = Grid(kFlat);
  const MarkerSurface surface(kRows, kCols, rest);
  const Eigen::VectorXd d =
      Displacements(rest, Grid([](double x, double) { return 8.0 + 0.5 * x; }));
  // Marker (3, 3) lost with its four neighbours: no valid pair within two steps along its row
  // nor its column. Each lost neighbour still has a pair on its far side.
  std::vector<bool> valid(kRows * kCols, true);
  for (int k : {3 * kCols + 3, 2 * kCols + 3, 4 * kCols + 3, 3 * kCols + 2, 3 * kCols + 4}) {
    valid[k] = false;
  }
  Eigen::VectorXd d_nan = d;
  d_nan(2 * kRows * kCols + 3 * kCols + 3) = NAN;  // also through a NaN
  int num_rest = -1;
  const Eigen::Matrix3Xd normals = surface.CalcNormals(d_nan, valid, &num_rest);
  EXPECT_EQ(num_rest, 1);
  EXPECT_THAT(normals.col(3 * kCols + 3).eval(), EigenNear(Eigen::Vector3d(0, 0, 1), 1e-15));
  const Eigen::Vector3d tilted = Eigen::Vector3d(-0.5, 0, 1).normalized();
  for (int k : {2 * kCols + 3, 4 * kCols + 3, 3 * kCols + 2, 3 * kCols + 4, 0}) {
    EXPECT_THAT(normals.col(k).eval(), EigenNear(tilted, 1e-12)) << k;
  }
}

TEST(MarkerSurface, OrientedOutwardsWhateverTheIndexOrder) {
  // Columns running along -x make t_col x t_row point to -z; the normals still point to +z.
  const std::vector<Eigen::Vector3d> rest = Grid(kFlat, -1.0);
  const MarkerSurface surface(kRows, kCols, rest);
  EXPECT_THAT(surface.rest_normals().col(5).eval(), EigenNear(Eigen::Vector3d(0, 0, 1), 1e-15));
  const Eigen::VectorXd d =
      Displacements(rest, Grid([](double x, double) { return 8.0 + 0.1 * x; }, -1.0));
  EXPECT_GT(surface.CalcNormals(d, {}).row(2).minCoeff(), 0.99);
}

TEST(MarkerSurface, DecomposeSplitsNormalAndTangentialAndMasksContact) {
  const std::vector<Eigen::Vector3d> rest = Grid(kFlat);
  const int n = kRows * kCols;
  const MarkerSurface surface(kRows, kCols, rest, {.contact_threshold_n = 0.05});
  Eigen::VectorXd forces = Eigen::VectorXd::Zero(3 * n);
  forces(0) = 0.03, forces(2 * n + 0) = -0.2;  // marker 0: presses with friction
  forces(2 * n + 1) = -0.04;                   // marker 1: below the threshold
  forces(2 * n + 2) = 0.3;                     // marker 2: pulls
  const ForceDecomposition split = surface.Decompose(Eigen::VectorXd::Zero(3 * n), {}, forces);
  EXPECT_DOUBLE_EQ(split.normal_force_n(0), 0.2);
  EXPECT_THAT(split.tangential_force_n.col(0).eval(), EigenNear(Eigen::Vector3d(0.03, 0, 0), 1e-15));
  EXPECT_DOUBLE_EQ(split.normal_force_n(2), -0.3);
  EXPECT_TRUE(split.contact[0]);
  EXPECT_FALSE(split.contact[1]);
  EXPECT_FALSE(split.contact[2]);
  EXPECT_EQ(split.num_contact, 1);
  EXPECT_EQ(split.num_rest_normals, 0);
  // On a tilted surface the split follows the local normal: a force along it is all normal.
  const Eigen::VectorXd d =
      Displacements(rest, Grid([](double x, double) { return 8.0 + 0.5 * x; }));
  const Eigen::Vector3d normal = Eigen::Vector3d(-0.5, 0, 1).normalized();
  forces.setZero();
  for (int axis = 0; axis < 3; ++axis) forces(axis * n + 10) = -0.7 * normal(axis);
  const ForceDecomposition tilted = surface.Decompose(d, {}, forces);
  EXPECT_NEAR(tilted.normal_force_n(10), 0.7, 1e-12);
  EXPECT_LT(tilted.tangential_force_n.col(10).norm(), 1e-12);
}

TEST(MarkerSurface, BadInputThrows) {
  const std::vector<Eigen::Vector3d> rest = Grid(kFlat);
  EXPECT_THROW(MarkerSurface(1, kRows * kCols, rest), Error);
  EXPECT_THROW(MarkerSurface(kRows, kCols + 1, rest), Error);
  EXPECT_THROW(MarkerSurface(kRows, kCols, rest, {.contact_threshold_n = -0.1}), Error);
  // Every marker at one point: no normal anywhere (Eigen leaves a vector uninitialised).
  const std::vector<Eigen::Vector3d> collapsed(kRows * kCols, Eigen::Vector3d::Zero());
  EXPECT_THROW(MarkerSurface(kRows, kCols, collapsed), Error);
  const MarkerSurface surface(kRows, kCols, rest);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * kRows * kCols);
  EXPECT_THROW(surface.CalcNormals(Eigen::VectorXd::Zero(6), {}), Error);
  EXPECT_THROW(surface.CalcNormals(zero, std::vector<bool>(3, true)), Error);
  EXPECT_THROW(surface.Decompose(zero, {}, Eigen::VectorXd::Zero(6)), Error);
}

}  // namespace
}  // namespace tac3d
