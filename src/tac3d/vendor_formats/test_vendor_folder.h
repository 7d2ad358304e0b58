#pragma once

// Test helpers of the vendor module: the real sensors' folder (../shared/realdata, skipped where
// absent) and a vendor calibration folder written from the HDL1-0001 fixture (test_hdl1_0001.h),
// so the importer's tests run without ../shared.

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/testing/testing.h"
#include "tac3d/vendor_formats/test_hdl1_0001_folder.h"
#include "tac3d/vendor_formats/vendor_calibration.h"

namespace tac3d::testing {

/// ../shared/realdata beside the source tree, or $TAC3D_REALDATA; nullopt where it is absent.
inline std::optional<std::string> RealDataDir() {
  const char* env = std::getenv("TAC3D_REALDATA");
  const std::string dir = env != nullptr && *env != '\0' ? env : TAC3D_DEFAULT_REALDATA_DIR;
  if (!std::filesystem::is_directory(std::filesystem::path(dir) / "tac3d")) return std::nullopt;
  return dir;
}

/// Skips the test, saying why, where the real data is absent.
#define TAC3D_REQUIRE_REALDATA(dir)                                                                      \
  const std::optional<std::string> dir##_or = ::tac3d::testing::RealDataDir();                           \
  if (!dir##_or) {                                                                                       \
    GTEST_SKIP() << "no real sensor data: ../shared/realdata (or $TAC3D_REALDATA) is absent, as in a "   \
                    "user's clone; the fixture tests cover the same code";                               \
  }                                                                                                      \
  const std::string dir = *dir##_or

/// Writes HDL1-0001's calibration, as the fixture holds it, in the vendor's folder layout (only
/// the keys tac3d reads); returns the folder.
inline std::string WriteFixtureVendorFolder(const std::string& name) {
  const std::string dir = MakeTempDir(name);
  WriteHdl1VendorFolder(dir);
  return dir;
}

/// The fixture's sensor as `tac3d import-vendor` makes it.
inline SensorConfig FixtureVendorSensor() { return ImportVendorSensor(WriteFixtureVendorFolder("hdl1_0001")); }

}  // namespace tac3d::testing
