#include "tac3d/vendor_formats/vendor_calibration.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;
namespace fixture = testing::hdl1_0001;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;

std::string ReadVendorText(const fs::path& path) {
  std::stringstream s;
  s << std::ifstream(path).rdbuf();
  return s.str();
}

// Replaces the first match of `pattern` in a file of the folder; fails the test if there is none.
void EditVendorFile(const std::string& folder, const char* file, const std::string& pattern, const std::string& replacement) {
  const fs::path path = fs::path(folder) / file;
  const std::string text = ReadVendorText(path);
  const std::string edited = std::regex_replace(text, std::regex(pattern), replacement,
                                                std::regex_constants::format_first_only);
  ASSERT_NE(edited, text) << pattern << " not in " << path;
  std::ofstream(path) << edited;
}

std::string CalibrationRefusalOf(const std::string& folder) {
  try {
    ReadVendorCalibration(folder);
  } catch (const Error& e) {
    return e.what();
  }
  return "accepted";
}

void ExpectFixtureValues(const VendorCalibration& c) {
  EXPECT_EQ(c.serial_number, "HDL1-0001");
  EXPECT_EQ(c.intrinsics.width, 1920);
  EXPECT_EQ(c.intrinsics.height, 1080);
  EXPECT_EQ(c.intrinsics.fx, fixture::kFx);
  EXPECT_EQ(c.intrinsics.cy, fixture::kCy);
  EXPECT_EQ(c.intrinsics.distortion, fixture::kDistortion);
  EXPECT_EQ(c.grid_rows, 20);
  EXPECT_EQ(c.grid_cols, 20);
  EXPECT_TRUE(c.camera_model.image_flip_x);
  EXPECT_FALSE(c.camera_model.image_flip_y);
  EXPECT_EQ(c.youngs_modulus_mpa, 0.5032);
  EXPECT_EQ(c.poisson_ratio, 0.49);
  EXPECT_EQ(c.camera_model.refraction.index_ratio, 1.4303);
  EXPECT_EQ(c.camera_model.refraction.height_mm, 0.0);
  for (int v = 0; v < 2; ++v) {
    const Rigid3& pose = c.camera_model.sensor_from_view[v];
    for (int k = 0; k < 3; ++k) EXPECT_EQ(pose.translation()(k), fixture::kViews[v].center_mm[k]);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(pose.linear()(k / 3, k % 3), fixture::kViews[v].rotation[k]) << k;
  }
  EXPECT_EQ(c.camera_model.datasheet.resultant_relative_error_pct.z(), fixture::kDatasheet[6][2]);
  EXPECT_EQ(c.camera_model.datasheet.position_noise_mm.x(), fixture::kDatasheet[0][0]);
  ASSERT_EQ(c.camera_model.reference_pixels[0].size(), 400u);
  ASSERT_EQ(c.camera_model.reference_pixels[1].size(), 400u);
  for (int i = 0; i < 400; ++i) {
    for (int v = 0; v < 2; ++v) {
      const auto& uv = fixture::kReferencePixels[400 * v + i];
      EXPECT_EQ(c.camera_model.reference_pixels[v][i], Eigen::Vector2d(uv[0], uv[1])) << "marker " << i;
    }
  }
}

TEST(VendorCalibration, ReadsTheFixtureFolder) {
  ExpectFixtureValues(ReadVendorCalibration(testing::WriteFixtureVendorFolder("vendor")));
}

TEST(VendorCalibration, ReadsTheRealHdl1Folder) {
  TAC3D_REQUIRE_REALDATA(realdata);
  ExpectFixtureValues(ReadVendorCalibration(realdata + "/tac3d/HDL1-0001/config"));
}

// The importer fits the dome to the reference positions it triangulates (0.044 mm median off the
// vendor's own): radius 33.43 mm, 0.051 mm RMS, centre 23.88 mm under the plane, pitch 1.016 mm.
// (The vendor's recorded positions give 33.40 mm, 0.0375 mm RMS, 23.85 mm: FitSphere below.)
TEST(VendorCalibration, ImportFitsTheDomeAndRoundTripsAsASensorConfig) {
  const SensorConfig c = testing::FixtureVendorSensor();
  ASSERT_TRUE(c.vendor_camera);
  const DomeFitConfig& dome = c.vendor_camera->dome;
  EXPECT_NEAR(dome.radius_mm, 33.43, 0.01);
  EXPECT_NEAR(dome.rms_mm, 0.051, 0.001);
  EXPECT_NEAR(dome.center_mm.z(), -23.88, 0.01);
  EXPECT_NEAR(dome.pitch_mm, 1.016, 0.001);
  EXPECT_EQ(c.markers.pitch_mm, dome.pitch_mm);
  EXPECT_EQ(c.elastic_body.youngs_modulus_mpa, 0.5032);
  EXPECT_EQ(c.elastic_body.poisson_ratio, 0.49);
  EXPECT_NEAR(c.elastic_body.outer_radius_mm - c.markers.depth_mm, dome.radius_mm, 1e-9);
  EXPECT_NEAR(c.SphereCenter().z(), dome.center_mm.z(), 1e-9);
  EXPECT_TRUE(c.mirrors.empty());
  EXPECT_NO_THROW(c.Validate());

  const std::string yaml = SensorConfigToYaml(c);
  const SensorConfig back = ParseSensorConfig(yaml, "imported.yaml");
  EXPECT_EQ(SensorConfigToYaml(back), yaml);
  ASSERT_TRUE(back.vendor_camera);
  EXPECT_EQ(back.vendor_camera->reference_pixels, c.vendor_camera->reference_pixels);
  EXPECT_TRUE(back.vendor_camera->sensor_from_view[1].matrix() == c.vendor_camera->sensor_from_view[1].matrix());
  EXPECT_EQ(back.vendor_camera->dome.rms_mm, dome.rms_mm);
  EXPECT_EQ(back.camera.intrinsics, c.camera.intrinsics);
  EXPECT_EQ(back.vendor_camera->serial_number, "HDL1-0001");
}

TEST(VendorCalibration, SensorConfigRefusesABrokenCameraModel) {
  const std::string yaml = SensorConfigToYaml(testing::FixtureVendorSensor());
  const auto refusal = [&](const std::string& pattern, const std::string& replacement) -> std::string {
    const std::string edited =
        std::regex_replace(yaml, std::regex(pattern), replacement, std::regex_constants::format_first_only);
    if (edited == yaml) return "pattern not found: " + pattern;
    try {
      ParseSensorConfig(edited, "imported.yaml");
    } catch (const Error& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_THAT(refusal(R"(type: vendor_pinhole_refraction)", "type: fisheye"), HasSubstr("camera_model.type"));
  EXPECT_THAT(refusal(R"(- \[214\.0, 215\.0,)", "- [2140.0, 215.0,"),
              HasSubstr("camera_model.reference_pixels[0] (left view, u)"));
  EXPECT_THAT(refusal(R"(\n +- \[214\.0, 215\.0, [0-9.]+, [0-9.]+\])", ""), HasSubstr("399 left pixels"));
  EXPECT_THAT(refusal(R"(index_ratio: 1\.4303)", "index_ratio: 0"), HasSubstr("camera_model.refraction.index_ratio"));
  EXPECT_THAT(refusal(R"(- \[-0\.8108347224032866)", "- [-0.7108347224032866"),
              HasSubstr("camera_model.views.left.rotation is not a rotation"));
}

// Each corruption: the file and line named.
TEST(VendorCalibration, RefusesACorruptedFolderNamingFileAndLine) {
  const auto corrupted = [](const char* file, const std::string& pattern, const std::string& replacement) {
    const std::string folder = testing::WriteFixtureVendorFolder("vendor");
    EditVendorFile(folder, file, pattern, replacement);
    return CalibrationRefusalOf(folder);
  };
  EXPECT_THAT(corrupted(kVendorMarkersFile, "\n[0-9]+,[0-9]+\n$", "\n"),
              MatchesRegex(".*markers.txt: 799 marker lines, the 20 x 20 grid of sensor.yaml needs 800.*"));
  EXPECT_THAT(corrupted(kVendorMarkersFile, "\n[0-9]+,[0-9]+\n", "\n1920,500\n"),
              HasSubstr("markers.txt: line 2: pixel (1920, 500) is outside the 1920 x 1080 image"));
  EXPECT_THAT(corrupted(kVendorMarkersFile, "^214,215", "214;215"), HasSubstr("markers.txt: line 1: '214;215'"));
  EXPECT_THAT(corrupted(kVendorMarkersFile, "^214,215", "214,x"), HasSubstr("markers.txt: line 1: 'x' is not a number"));
  EXPECT_THAT(corrupted(kVendorParametersFile, R"(rotation: \[-0\.81)", "rotation: [-0.71"),
              HasSubstr("parameters.yaml: line 20: extrinsic.left.rotation: is not a rotation"));
  EXPECT_THAT(corrupted(kVendorParametersFile, "  n21: [0-9.]+\n", ""),
              MatchesRegex(".*parameters.yaml: line [0-9]+: refraction.n21: missing.*"));
  EXPECT_THAT(corrupted(kVendorParametersFile, "fx: [0-9.]+", "fx: abc"),
              HasSubstr("parameters.yaml: line 2: intrinsic.fx: 'abc' is not a number"));
  EXPECT_THAT(corrupted(kVendorParametersFile, "s: 0", "s: 0.5"), HasSubstr("parameters.yaml: line 6: intrinsic.s"));
  EXPECT_THAT(corrupted(kVendorParametersFile, "cx: [0-9.]+", "cx: 2000"),
              HasSubstr("principal point (2000, 577.87"));
  EXPECT_THAT(corrupted(kVendorSensorFile, "nx: 20", "nx: 21"),
              HasSubstr("markers.txt: 800 marker lines, the 21 x 20 grid of sensor.yaml needs 840"));
  EXPECT_THAT(corrupted(kVendorSensorFile, "nx: 20", "nx: 19"),
              HasSubstr("markers.txt: line 761: more than the 2 x 380 marker lines the 19 x 20 grid"));
  EXPECT_THAT(corrupted(kVendorSensorFile, "flipX: true", "flipX: maybe"),
              HasSubstr("sensor.yaml: line 9: pipeline[0].config.flipX: must be true or false"));
  EXPECT_THAT(corrupted(kVendorDatasheetFile, "  Efm: .*\n", ""), HasSubstr("datasheet.yaml: line 6: Accuracy.Efm: missing"));  // the mapping's line
  const std::string folder = testing::WriteFixtureVendorFolder("vendor");
  fs::remove(fs::path(folder) / kVendorDatasheetFile);
  EXPECT_THAT(CalibrationRefusalOf(folder), HasSubstr("datasheet.yaml"));
}

// Files each well formed that do not agree: the import refuses them, naming the file, instead
// of a sensor whose every position would be millimetres off.
TEST(VendorCalibration, ImportRefusesViewsNamingOtherMarkersAndAnImplausibleNoise) {
  const auto import_refusal = [](const std::string& folder) -> std::string {
    try {
      ImportVendorSensor(folder);
    } catch (const Error& e) {
      return e.what();
    }
    return "accepted";
  };
  std::string folder = testing::WriteFixtureVendorFolder("vendor");
  ASSERT_EQ(import_refusal(folder), "accepted");
  // Two neighbours' right-view lines swapped, in the middle of a row: each ray pair still meets,
  // but at the other marker's depth.
  const fs::path markers = fs::path(folder) / kVendorMarkersFile;
  std::vector<std::string> lines;
  {
    std::ifstream in(markers);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  ASSERT_EQ(lines.size(), 800u);
  std::swap(lines[400 + 210], lines[400 + 211]);
  {
    std::ofstream out(markers);
    for (const std::string& line : lines) out << line << "\n";
  }
  EXPECT_THAT(import_refusal(folder), AllOf(HasSubstr("markers.txt"),
                                            HasSubstr("do both views' lines name the same markers?")));
  // The datasheet's position noise picks the force inverse's weight: 0 and 1e308 are refused.
  for (const char* noise : {"0", "1e308"}) {
    folder = testing::WriteFixtureVendorFolder("vendor");
    EditVendorFile(folder, kVendorDatasheetFile, "Np: \\[[^,]+,", fmt::format("Np: [{},", noise));
    EXPECT_THAT(import_refusal(folder), HasSubstr("camera_model.datasheet.position_noise_mm[0]")) << noise;
  }
}

TEST(VendorCalibration, RefusesACorruptedCopyOfTheRealHdl1Folder) {
  TAC3D_REQUIRE_REALDATA(realdata);
  const std::string copy = testing::MakeTempDir("HDL1-0001");
  fs::copy(realdata + "/tac3d/HDL1-0001/config", copy, fs::copy_options::recursive);
  ASSERT_EQ(CalibrationRefusalOf(copy), "accepted");
  EditVendorFile(copy, kVendorMarkersFile, R"(\n([0-9]+),([0-9]+)\r?\n)", "\n$1,1080\n");  // the vendor's lines end in CRLF
  EXPECT_THAT(CalibrationRefusalOf(copy), MatchesRegex(".*markers.txt: line 2: pixel \\([0-9]+, 1080\\) is outside the 1920 x "
                                             "1080 image of sensor.yaml"));
  fs::copy(realdata + "/tac3d/HDL1-0001/config/" + kVendorMarkersFile, fs::path(copy) / kVendorMarkersFile,
           fs::copy_options::overwrite_existing);
  EditVendorFile(copy, kVendorParametersFile, R"(rotation: \[-0\.8093)", "rotation: [0.8093");
  EXPECT_THAT(CalibrationRefusalOf(copy), MatchesRegex(".*parameters.yaml: line [0-9]+: extrinsic.right.rotation: is not a "
                                             "rotation.*"));
}

// Issue 23's fact, on the vendor's recorded reference positions: a sphere 0.038 mm RMS off them
// (radius 33.3 mm, centre 23.75 mm under the plane by an algebraic fit; the geometric fit here,
// of the same RMS to 1e-4 mm, puts them at 33.40 mm and 23.85 mm: a 20 mm cap of a 33 mm sphere
// pins its radius to about 0.1 mm), pitch 1.016 mm.
TEST(FitSphere, TheVendorsReferencePositionsLieOnASphere) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : fixture::kReferencePositionsMm) points.emplace_back(p[0], p[1], p[2]);
  const SphereFit fit = FitSphere(points);
  EXPECT_NEAR(fit.rms, 0.0375, 0.0005);
  EXPECT_NEAR(fit.radius, 33.40, 0.01);
  EXPECT_NEAR(fit.center.z(), -23.85, 0.01);
  EXPECT_NEAR(MeanGridPitch(points, 20, 20), 1.016, 0.001);
}

TEST(FitSphere, RecoversASphereAndRefusesAPlane) {
  std::vector<Eigen::Vector3d> points;
  const Eigen::Vector3d center(1, -2, -20);
  for (int i = 0; i < 50; ++i) {
    const double a = 0.1 * i, b = 0.37 * i;
    points.push_back(center + 25.0 * Eigen::Vector3d(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), std::cos(a)));
  }
  const SphereFit fit = FitSphere(points);
  EXPECT_THAT(fit.center, EigenNear(center, 1e-9));
  EXPECT_NEAR(fit.radius, 25.0, 1e-9);
  EXPECT_LT(fit.rms, 1e-9);
  for (Eigen::Vector3d& p : points) p.z() = 0;
  EXPECT_THROW(FitSphere(points), Error);
  EXPECT_THROW(FitSphere({points[0], points[1], points[2]}), Error);
}

}  // namespace
}  // namespace tac3d
