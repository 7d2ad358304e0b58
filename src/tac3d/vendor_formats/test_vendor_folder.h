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
#include "tac3d/vendor_formats/vendor_recording.h"

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

// A recording of the fixture's sensor whose frame 0 holds the fixture's reference positions
// (as positions - displacements) and frame 1 the same moved 1 mm in z.
inline VendorRecording FixtureRecording() {
  VendorRecording r;
  r.serial_number = "HDL1-0001";
  std::vector<double> positions, displacements;
  for (int frame = 0; frame < 2; ++frame) {
    for (const auto& p : hdl1_0001::kReferencePositionsMm) {
      for (int k = 0; k < 3; ++k) {
        const double d = frame == 1 && k == 2 ? -1.0 : 0.01 * k;
        positions.push_back(p[k] + d);
        displacements.push_back(d);
      }
    }
  }
  const auto array = [](std::vector<std::int64_t> shape, const std::vector<double>& values) {
    NpyArray a;
    a.shape = std::move(shape);
    a.data.assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
    return a;
  };
  r.positions = array({2, 400, 3}, positions);
  r.displacements = array({2, 400, 3}, displacements);
  r.forces = array({2, 400, 3}, std::vector<double>(2400, 0.0));
  r.resultant_force = array({2, 1, 3}, std::vector<double>(6, 0.0));
  r.resultant_moment = r.resultant_force;
  r.send_timestamp = array({2}, {0.0, 0.033});
  r.index.type = NpyType::kInt64;
  r.index.shape = {2};
  r.index.data.assign(16, '\0');
  return r;
}

inline NpyArray DoubleArray(std::vector<std::int64_t> shape, const std::vector<double>& values) {
  NpyArray a;
  a.shape = std::move(shape);
  a.data.assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  return a;
}

// The fixture's two recorded frames of HDL1-0001 (a press of about 5.37 N held).
inline VendorRecording FixtureForceRecording() {
  VendorRecording r = FixtureRecording();
  std::vector<double> positions, displacements, forces, resultants;
  for (const hdl1_0001::RecordedFrame& frame : hdl1_0001::kRecordedFrames) {
    for (int i = 0; i < 400; ++i) {
      for (int k = 0; k < 3; ++k) {
        positions.push_back(hdl1_0001::kReferencePositionsMm[i][k] + frame.displacements_mm[i][k]);
        displacements.push_back(frame.displacements_mm[i][k]);
        forces.push_back(frame.forces_n[i][k]);
      }
    }
    resultants.insert(resultants.end(), frame.resultant_force_n.begin(), frame.resultant_force_n.end());
  }
  r.positions = DoubleArray({2, 400, 3}, positions);
  r.displacements = DoubleArray({2, 400, 3}, displacements);
  r.forces = DoubleArray({2, 400, 3}, forces);
  r.resultant_force = DoubleArray({2, 1, 3}, resultants);
  return r;
}

}  // namespace tac3d::testing
