#include "tac3d/tracking/grid_indexer.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A 20 x 20 lattice seen obliquely (a homography), pitch 9-16 px like the sensor's halves.
struct Lattice {
  std::vector<Eigen::Vector2d> uv;
  std::vector<double> pitch;
};

Lattice MakeLattice() {
  Eigen::Matrix3d h;
  h << 14.0, 0.5, 80.0,  //
      -1.5, 12.0, 100.0,  //
      -0.0012, 0.0, 1.0;
  Lattice l;
  for (int r = 0; r < 20; ++r) {
    for (int c = 0; c < 20; ++c) l.uv.push_back((h * Eigen::Vector3d(c, r, 1)).hnormalized());
  }
  for (int i = 0; i < 400; ++i) {
    double p = 1e9;
    for (int j : {i - 1, i + 1, i - 20, i + 20}) {
      if (j < 0 || j >= 400 || (std::abs(j - i) == 1 && j / 20 != i / 20)) continue;
      p = std::min(p, (l.uv[j] - l.uv[i]).norm());
    }
    l.pitch.push_back(p);
  }
  return l;
}

// The real grid: the lattice turned by `rotation_deg` about its middle, scaled, offset,
// with centroid noise; a fraction of the markers missing and some spurious blobs added.
// Returns the detections and, per marker, the index of its detection (-1 if missing).
std::vector<Eigen::Vector2d> Observe(const Lattice& l, const Eigen::Vector2d& offset_px,
                                     double rotation_deg, double scale, double missing,
                                     int spurious, std::vector<int>& truth) {
  std::mt19937 rng(testing::kRandomSeed);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::Vector2d middle = Eigen::Vector2d::Zero();
  for (const auto& p : l.uv) middle += p / l.uv.size();
  const Eigen::Rotation2Dd rotation(rotation_deg * M_PI / 180);
  std::vector<Eigen::Vector2d> detections;
  truth.assign(l.uv.size(), -1);
  for (size_t i = 0; i < l.uv.size(); ++i) {
    if (unit(rng) < missing) continue;
    truth[i] = static_cast<int>(detections.size());
    detections.push_back(middle + scale * (rotation * (l.uv[i] - middle)) + offset_px +
                         Eigen::Vector2d(noise(rng), noise(rng)));
  }
  for (int k = 0; k < spurious; ++k) {
    detections.emplace_back(60 + 280 * unit(rng), 80 + 300 * unit(rng));
  }
  // Detection order carries no information.
  std::vector<int> order(detections.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<Eigen::Vector2d> shuffled(detections.size());
  std::vector<int> where(detections.size());
  for (size_t k = 0; k < order.size(); ++k) {
    shuffled[k] = detections[order[k]];
    where[order[k]] = static_cast<int>(k);
  }
  for (int& t : truth) t = t >= 0 ? where[t] : -1;
  return shuffled;
}

TEST(IndexGrid, OffsetRotatedScaledGridWithMissingAndSpuriousBlobs) {
  const Lattice l = MakeLattice();
  // The offset is over half the smallest pitch, so nearest neighbours alone would fail.
  for (const Eigen::Vector2d& offset : {Eigen::Vector2d(7.0, -5.0), Eigen::Vector2d(-11.0, 3.0)}) {
    std::vector<int> truth;
    const auto detections = Observe(l, offset, 2.0, 1.03, 0.1, 40, truth);
    const std::vector<GridIndex> candidates = IndexGrid(detections, l.uv, l.pitch, {});
    ASSERT_FALSE(candidates.empty());
    // Undeformed, the right indexing matches the most markers: it comes first.
    const GridIndex& index = candidates.front();
    int matched = 0, wrong = 0;
    for (int i = 0; i < 400; ++i) {
      if (index.detection_of_marker[i] < 0) continue;
      ++matched;
      wrong += index.detection_of_marker[i] != truth[i];
    }
    const int present = static_cast<int>(400 - std::count(truth.begin(), truth.end(), -1));
    EXPECT_EQ(wrong, 0) << offset.transpose();
    EXPECT_EQ(matched, present) << offset.transpose();
    EXPECT_EQ(index.summary.matches, matched);
    // The residual about the affine map: the centroid noise and the part of the rotation
    // and scale about the lattice's middle an affine map of the oblique view cannot take.
    EXPECT_LT(index.summary.rms_px, 1.0);
    for (size_t k = 1; k < candidates.size(); ++k) {
      EXPECT_LT(candidates[k].summary.matches, index.summary.matches);
    }
  }
}

TEST(IndexGrid, NothingToMatch) {
  const Lattice l = MakeLattice();
  EXPECT_TRUE(IndexGrid({}, l.uv, l.pitch, {}).empty());
  // Two blobs cannot fix an affine map, nor can blobs on one line.
  EXPECT_TRUE(IndexGrid({l.uv[0], l.uv[1]}, l.uv, l.pitch, {}).empty());
  EXPECT_TRUE(IndexGrid({l.uv[0], l.uv[1], l.uv[2], l.uv[3]}, l.uv, l.pitch, {}).empty());
}

TEST(IndexGrid, BadArgumentsThrow) {
  const Lattice l = MakeLattice();
  EXPECT_THROW(IndexGrid(l.uv, l.uv, {1.0, 2.0}, {}), Error);
  GridIndexOptions options;
  options.hypotheses = 0;
  EXPECT_THROW(IndexGrid(l.uv, l.uv, l.pitch, options), Error);
  options = {};
  options.max_offset_px = -1;
  EXPECT_THROW(IndexGrid(l.uv, l.uv, l.pitch, options), Error);
}

}  // namespace
}  // namespace tac3d
