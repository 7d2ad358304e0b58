// Seeded fuzzing of the run file's reader (as the sensor config's):
// mutated run files, and run files of many sensors, must load or throw tac3d::Error, never
// crash, hang or allocate without bound.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <string>

#include "tac3d/runtime/run_file.h"
#include "tac3d/runtime/sensor_group.h"
#include "tac3d/sensor/test_yaml_mutator.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::runtime {
namespace {

// Every key of a sensor, each source kind, paths relative to the file's folder.
constexpr char kSeedRunFile[] =
    "sensors:\n"
    "  - sn: THUMB\n"
    "    source: dataset:twin/thumb\n"
    "    config: thumb.yaml\n"
    "    gains: [1.1, 1.2, 0.9]\n"
    "    weight: 0.05\n"
    "    reference_frames: 20\n"
    "    drift: rezero\n"
    "    drift_time_constant_s: 10\n"
    "    speed: 1\n"
    "    udp: 127.0.0.1:9988\n"
    "    record: thumb.rec\n"
    "    record_images: true\n"
    "    overwrite: false\n"
    "  - sn: INDEX\n"
    "    source: camera:2\n"
    "    fps: 30\n"
    "    exposure: 100\n"
    "  - {sn: MIDDLE, source: recording:middle.rec, speed: 0}\n"
    "  - {sn: RING, source: images}\n";

TEST(RunFileFuzz, MutatedFilesLoadOrThrowErrorWithinBoundedMemoryAndTime) {
  const std::string dir = testing::MakeTempDir("run_file_fuzz");
  ASSERT_EQ(ParseRunFile(kSeedRunFile, "seed.yaml", dir).size(), 4u);
  const testing::FuzzCounts counts = testing::FuzzYamlReader(
      kSeedRunFile, [&](const std::string& text) { ParseRunFile(text, "fuzz.yaml", dir); }, "run files");
  EXPECT_GT(counts.iterations, 1000) << "too few iterations in the time bound: a slow path?";
  EXPECT_GT(counts.refused, counts.iterations / 4);
  EXPECT_GT(counts.loaded, 0);
}

// Issue 22 defect 6: 2000 sensors were read and opened until std::bad_alloc (20 s). Any number
// past the limit is refused at once, naming the first sensor too many.
TEST(RunFileFuzz, ManySensorsAreRefusedAtTheFirstPastTheLimit) {
  for (const int n : {kMaxSensors + 1, 2000}) {
    std::string text = "sensors:\n";
    for (int i = 0; i < n; ++i) text += fmt::format("  - {{sn: S{}, source: images}}\n", i);
    try {
      ParseRunFile(text, "many.yaml", "/tmp");
      ADD_FAILURE() << n << " sensors accepted";
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), fmt::format("many.yaml: line {}: sensors[{}]: a run holds at most {} sensors",
                                         kMaxSensors + 2, kMaxSensors, kMaxSensors)
                                 .c_str());
    }
  }
}

}  // namespace
}  // namespace tac3d::runtime
