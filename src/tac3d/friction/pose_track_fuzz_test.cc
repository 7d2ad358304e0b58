// Seeded fuzzing of the pose CSV reader: mutated files, /dev/zero, a
// folder and a FIFO each load or throw tac3d::Error, within bounded time and memory.
#include <gtest/gtest.h>

#include "tac3d/friction/pose_track.h"
#include "tac3d/testing/csv_fuzz.h"

namespace tac3d::friction {
namespace {

TEST(PoseTrackFuzz, MutatedFilesLoadOrThrowErrorWithinBoundedMemoryAndTime) {
  const std::string seed =
      "# motion capture\nt_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n"
      "0.5,1,2,3,0.7071068,0,0,0.7071068\n1,2,4,6,0,0,0,1\n";
  const int iterations = tac3d::testing::FuzzCsvReader(
      seed, [](const std::string& path) { PoseTrack::ReadCsv(path); });
  EXPECT_GT(iterations, 200) << "too few iterations in the time bound: a slow path?";
}

}  // namespace
}  // namespace tac3d::friction
