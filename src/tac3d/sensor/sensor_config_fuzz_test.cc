// Seeded fuzzing of the sensor YAML reader: mutated configs, some with
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

// A real sensor's config (camera_model, as `tac3d import-vendor` writes it) on a 2 x 2 grid, so
// the vendor camera model's reader is fuzzed too.
std::string SeedVendorConfigYaml() {
  SensorConfig c;
  c.markers.rows = c.markers.cols = 2;
  VendorCameraModelConfig v;
  v.serial_number = "HDL1-0001";
  v.image_flip_x = true;
  v.sensor_from_view[1].translation() = Eigen::Vector3d(-12, 0, -32);
  v.refraction.index_ratio = 1.4303;
  for (int i = 0; i < 4; ++i) {
    v.reference_pixels[0].emplace_back(100 + i, 200);
    v.reference_pixels[1].emplace_back(400 + i, 200);
  }
  v.dome = {Eigen::Vector3d(0, 0, -23.75), 33.3, 0.038, 0.1, 1.016};
  v.datasheet.position_noise_mm = Eigen::Vector3d(0.001, 0.001, 0.004);
  v.datasheet.resultant_relative_error_pct = Eigen::Vector3d(2.3, 1.9, 4.9);
  c.vendor_camera = v;
  return SensorConfigToYaml(c);
}

TEST(SensorConfigFuzz, MutatedVendorCameraModelsLoadOrThrowError) {
  const std::string seed = SeedVendorConfigYaml();
  ASSERT_TRUE(ParseSensorConfig(seed, "seed.yaml").vendor_camera);
  const testing::FuzzCounts counts =
      testing::FuzzYamlReader(seed, [](const std::string& text) { ParseSensorConfig(text, "fuzz.yaml"); }, "configs");
  EXPECT_GT(counts.iterations, 1000) << "too few iterations in the time bound: a slow path?";
  EXPECT_GT(counts.refused, counts.iterations / 2);
}

}  // namespace
}  // namespace tac3d
