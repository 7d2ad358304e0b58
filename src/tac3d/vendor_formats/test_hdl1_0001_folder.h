#pragma once

// Test and benchmark helper (no GoogleTest): the HDL1-0001 fixture (test_hdl1_0001.h) written out
// as a vendor calibration folder, for ImportVendorSensor.

#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "tac3d/vendor_formats/test_hdl1_0001.h"
#include "tac3d/vendor_formats/vendor_calibration.h"

namespace tac3d::testing {

inline void WriteVendorTestFile(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

/// Writes HDL1-0001's calibration, as the fixture holds it, into `dir` in the vendor's folder
/// layout (only the keys tac3d reads).
inline void WriteHdl1VendorFolder(const std::filesystem::path& dir) {
  namespace f = hdl1_0001;
  WriteVendorTestFile(dir / kVendorSensorFile,
            fmt::format("version: 3.2.1\nSN: HDL1-0001\npipeline:\n- name: InputSource\n  threads: 1\n  config:\n"
                        "    width: {}\n    height: {}\n    flipX: {}\n    flipY: {}\n- name: DMP3_by_Zhang\n"
                        "  config:\n    nx: {}\n    ny: {}\n",
                        f::kWidth, f::kHeight, f::kFlipX, f::kFlipY, f::kGridCols, f::kGridRows));
  std::string parameters = fmt::format(
      "intrinsic:\n  fx: {}\n  fy: {}\n  cx: {}\n  cy: {}\n  s: 0\n\ndistortion:\n  k1: {}\n  k2: {}\n  p1: {}\n"
      "  p2: {}\n  k3: {}\n\nextrinsic:\n",
      f::kFx, f::kFy, f::kCx, f::kCy, f::kDistortion[0], f::kDistortion[1], f::kDistortion[2], f::kDistortion[3],
      f::kDistortion[4]);
  for (int v = 0; v < 2; ++v) {
    const f::View& view = f::kViews[v];
    parameters += fmt::format("  {}:\n    x: {}\n    y: {}\n    z: {}\n    rotation: [{}]\n", v == 0 ? "left" : "right",
                              view.center_mm[0], view.center_mm[1], view.center_mm[2], fmt::join(view.rotation, ", "));
  }
  parameters += fmt::format("\nrefraction:\n  n21: {}\n  h0: {}\n  theta: {}\n  phi: {}\n", f::kN21, f::kH0,
                            f::kTheta, f::kPhi);
  WriteVendorTestFile(dir / kVendorParametersFile, parameters);
  std::string datasheet = fmt::format("Parameters:\n  E: {}\n  P: {}\n\nAccuracy:\n", f::kYoungsModulusMpa,
                                      f::kPoissonRatio);
  const char* keys[] = {"Np", "Nf", "Nfm", "Dp", "Df", "Dfm", "Efm"};
  for (int k = 0; k < 7; ++k) datasheet += fmt::format("  {}: [{}]\n", keys[k], fmt::join(f::kDatasheet[k], ", "));
  WriteVendorTestFile(dir / kVendorDatasheetFile, datasheet);
  std::string markers;
  for (const auto& uv : f::kReferencePixels) markers += fmt::format("{},{}\n", uv[0], uv[1]);
  WriteVendorTestFile(dir / kVendorMarkersFile, markers);
}

}  // namespace tac3d::testing
