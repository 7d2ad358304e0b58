#include "tac3d/twin/marker_motion.h"

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

TEST(MarkerMotion, StandardFieldsMoveAsNamed) {
  const auto markers = SensorConfig{}.MarkerPositions();
  const auto motions = StandardMarkerMotions();
  ASSERT_EQ(motions.size(), 3u);

  const auto sheared = motions[0].Apply(markers);
  for (size_t i = 0; i < markers.size(); ++i) {
    EXPECT_THAT((sheared[i] - markers[i]).eval(), EigenNear(Eigen::Vector3d(0.5, 0, 0), 1e-12));
  }

  const auto dented = motions[1].Apply(markers);
  double deepest = 0;
  for (size_t i = 0; i < markers.size(); ++i) {
    EXPECT_LE(dented[i].z(), markers[i].z() + 1e-12);
    EXPECT_EQ(dented[i].head<2>(), markers[i].head<2>());
    deepest = std::max(deepest, markers[i].z() - dented[i].z());
  }
  // The markers next to the axis are 1 mm down, less the sphere's sag over half a pitch.
  EXPECT_NEAR(deepest, 1.0, 0.05);

  const auto twisted = motions[2].Apply(markers);
  // The marker nearest the axis turns by almost 5 deg about it; radii are kept.
  const Eigen::Vector2d a = markers[210].head<2>(), b = twisted[210].head<2>();
  EXPECT_NEAR(a.norm(), b.norm(), 1e-12);
  EXPECT_NEAR(RadToDeg(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b))), 5.0, 0.05);
}

}  // namespace
}  // namespace tac3d
