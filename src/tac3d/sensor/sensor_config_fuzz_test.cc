// Seeded fuzzing of the sensor YAML reader (issues 14 and 22): mutated configs, some with
// nested aliases, must load or throw tac3d::Error, never crash, hang or allocate without bound.
// The address space is capped so an allocation driven by a value in the file shows up as
// std::bad_alloc, which fails the test.
#include <gtest/gtest.h>

#include <string>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/sensor/test_yaml_mutator.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A config with mirrors and virtual cameras, so every reader path is reached.
std::string SeedConfigYaml() {
  SensorConfig c;
  for (int i = 0; i < 4; ++i)
    c.mirrors.push_back({"mirror_" + std::to_string(i + 1), Rectangle3{}});
  for (ImageHalf half : kImageHalves) {
    VirtualCameraConfig v;
    v.half = half;
    v.intrinsics = c.camera.intrinsics;
    v.column_begin = half == ImageHalf::kLeft ? 0 : 320;
    v.column_end = v.column_begin + 320;
    c.virtual_cameras.push_back(v);
  }
  return SensorConfigToYaml(c);
}

TEST(SensorConfigFuzz, MutatedFilesLoadOrThrowErrorWithinBoundedMemoryAndTime) {
  const std::string seed = SeedConfigYaml();
  ASSERT_NO_THROW(ParseSensorConfig(seed, "seed.yaml"));
  const testing::FuzzCounts counts =
      testing::FuzzYamlReader(seed, [](const std::string& text) { ParseSensorConfig(text, "fuzz.yaml"); }, "configs");
  EXPECT_GT(counts.iterations, 1000) << "too few iterations in the time bound: a slow path?";
  EXPECT_GT(counts.refused, counts.iterations / 2);
}

}  // namespace
}  // namespace tac3d
