// The per-frame path of ForceReconstructor allocates nothing (CONVENTIONS.md, Performance):
// malloc is counted around Reconstruct (testing/malloc_counter.h interposes glibc's malloc).

#include <gtest/gtest.h>

#include "tac3d/force/force_reconstructor.h"
#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/testing/malloc_counter.h"

namespace tac3d {
namespace {

TEST(ForceReconstructor, PerFrameReconstructAllocatesNothing) {
  if (!testing::MallocIsCounted()) GTEST_SKIP() << "malloc is not countable under AddressSanitizer";
  const SyntheticCompliance model = CalcSyntheticCompliance({.rows = 6, .cols = 6});
  ForceReconstructor reconstructor(model.h, model.marker_positions, {.weight = 1e-3});
  // A press of 0.5 N into the body on four markers.
  Eigen::VectorXd press = Eigen::VectorXd::Zero(model.h.rows());
  for (int i : {14, 15, 20, 21}) press(2 * 36 + i) = -0.5;
  const Eigen::VectorXd d = model.h * press;
  std::vector<bool> valid(36, true);
  valid[7] = valid[20] = false;
  ForceFrame frame;
  // The first frames size the frame and build the cache for the mask; the counter must see
  // the malloc they do, or the interposition is not working.
  long before = testing::MallocCalls();
  reconstructor.Reconstruct(d, {}, &frame);
  reconstructor.Reconstruct(d, valid, &frame);
  ASSERT_GT(testing::MallocCalls(), before);
  before = testing::MallocCalls();
  for (int k = 0; k < 10; ++k) {
    reconstructor.Reconstruct(d, valid, &frame);
    reconstructor.Reconstruct(d, valid, &frame);
  }
  EXPECT_EQ(testing::MallocCalls(), before);
  // The press covers the grid: the contact-support re-solve ran too.
  EXPECT_TRUE(frame.support_refined);
  EXPECT_GT(frame.num_support_markers, 0);
  // Without invalid markers, too (the cache stays).
  reconstructor.Reconstruct(d, {}, &frame);
  EXPECT_EQ(testing::MallocCalls(), before);
  // A different mask every frame (markers flickering at the contact's edge): the restricted
  // problem is refactored each frame, in storage sized once by the first frames.
  std::vector<bool> other(36, true);
  other[3] = other[21] = other[30] = false;
  reconstructor.Reconstruct(d, other, &frame);
  before = testing::MallocCalls();
  for (int k = 0; k < 10; ++k) {
    reconstructor.Reconstruct(d, valid, &frame);
    reconstructor.Reconstruct(d, other, &frame);
    reconstructor.Reconstruct(d, {}, &frame);
  }
  EXPECT_EQ(testing::MallocCalls(), before);
  EXPECT_TRUE(frame.support_refined);
}

}  // namespace
}  // namespace tac3d
