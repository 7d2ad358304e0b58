#include "tac3d/stereo/marker_field.h"

#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::DefaultSensor;

// Exact pixels of the undeformed markers pushed in by a smooth dent.
struct Views {
  std::vector<Eigen::Vector3d> truth;
  std::vector<Eigen::Vector2d> left, right;
};
Views ExactViews(const StereoRig& rig) {
  Views v;
  v.truth = DefaultSensor().MarkerPositions();
  for (auto& p : v.truth) p.z() -= 0.8 * std::exp(-p.head<2>().squaredNorm() / 16.0);
  for (const auto& p : v.truth) {
    v.left.push_back(*rig.Project(ImageHalf::kLeft, p));
    v.right.push_back(*rig.Project(ImageHalf::kRight, p));
  }
  return v;
}

double WorstError(const MarkerField& f, const std::vector<Eigen::Vector3d>& truth) {
  double worst = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    if (f.valid[i]) worst = std::max(worst, (f.positions[i] - truth[i]).norm());
  }
  return worst;
}

TEST(MarkerTriangulator, RefractionModelsFromNoneToExact) {
  MarkerTriangulatorOptions options;
  options.model = RefractionModel::kNone;
  const MarkerTriangulator none(DefaultSensor(), options);
  options.model = RefractionModel::kPolynomial;
  const MarkerTriangulator polynomial(DefaultSensor(), options);
  options.model = RefractionModel::kExact;
  const MarkerTriangulator exact(DefaultSensor(), options);
  const Views v = ExactViews(polynomial.rig());
  MarkerField f_none, f_poly, f_exact;
  none.Triangulate(v.left, v.right, f_none);
  polynomial.Triangulate(v.left, v.right, f_poly);
  exact.Triangulate(v.left, v.right, f_exact);
  EXPECT_EQ(f_poly.CountValid(), 400);
  EXPECT_EQ(f_exact.CountValid(), 400);
  EXPECT_GT(WorstError(f_none, v.truth), 1.0);
  EXPECT_LT(WorstError(f_poly, v.truth), 0.005);
  EXPECT_LT(WorstError(f_exact, v.truth), 1e-6);
}

TEST(MarkerTriangulator, LostAndMismatchedMarkersAreFlagged) {
  const MarkerTriangulator triangulator(DefaultSensor());
  Views v = ExactViews(triangulator.rig());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  v.left[7] = Eigen::Vector2d(nan, nan);
  std::swap(v.right[100], v.right[250]);  // a pairing mistake
  MarkerField f;
  triangulator.Triangulate(v.left, v.right, f);
  EXPECT_FALSE(f.valid[7]);
  EXPECT_FALSE(f.valid[100]);
  EXPECT_FALSE(f.valid[250]);
  EXPECT_EQ(f.CountValid(), 397);
  EXPECT_LT(WorstError(f, v.truth), 0.005);
  EXPECT_THROW(triangulator.Triangulate(v.left, {}, f), Error);
}

TEST(DisplacementReference, MeanOfStaticFramesAndZeroing) {
  MarkerField a, b;
  a.positions = {{0, 0, 1}, {1, 0, 1}};
  b.positions = {{0, 0, 1.2}, {5, 5, 5}};
  a.valid = {1, 1};
  b.valid = {1, 0};
  a.displacements = b.displacements = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  DisplacementReference reference;
  EXPECT_TRUE(reference.empty());
  reference.Set({a, b});
  EXPECT_THAT(reference.positions()[0], EigenNear(Eigen::Vector3d(0, 0, 1.1), 1e-12));
  EXPECT_THAT(reference.positions()[1], EigenNear(Eigen::Vector3d(1, 0, 1), 1e-12));
  MarkerField now = a;
  now.positions[1] = {1.5, 0, 1};
  reference.Apply(now);
  EXPECT_THAT(now.displacements[1], EigenNear(Eigen::Vector3d(0.5, 0, 0), 1e-12));
  // Re-zeroing on the present state.
  reference.Set({now});
  reference.Apply(now);
  EXPECT_THAT(now.displacements[1], EigenNear(Eigen::Vector3d::Zero(), 1e-12));
  EXPECT_THROW(reference.Set({}), Error);
}

TEST(DisplacementReference, MarkerNeverSeenHasNoDisplacement) {
  MarkerField a;
  a.positions = {{0, 0, 1}, {1, 0, 1}};
  a.valid = {1, 0};
  a.displacements.assign(2, Eigen::Vector3d::Zero());
  DisplacementReference reference;
  reference.Set({a});
  MarkerField now = a;
  now.valid = {1, 1};
  reference.Apply(now);
  EXPECT_FALSE(now.valid[1]);
}

}  // namespace
}  // namespace tac3d
