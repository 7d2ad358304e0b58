// Seeded fuzzing of the marker-position CSV reader: mutated files,
// /dev/zero, a folder and a FIFO each load or throw tac3d::Error, within bounded time and memory.
#include <gtest/gtest.h>

#include "tac3d/io/marker_csv.h"
#include "tac3d/testing/csv_fuzz.h"

namespace tac3d {
namespace {

TEST(MarkerCsvFuzz, MutatedFilesLoadOrThrowErrorWithinBoundedMemoryAndTime) {
  const std::string seed = "# undeformed\nx_mm,y_mm,z_mm\n-1.27,-1.27,7.5\n0,-1.27,7.5\n1.27,0,7.5\n";
  const int iterations = testing::FuzzCsvReader(
      seed, [](const std::string& path) { ReadMarkerPositionsCsv(path); });
  EXPECT_GT(iterations, 200) << "too few iterations in the time bound: a slow path?";
}

}  // namespace
}  // namespace tac3d
