#include "tac3d/sensor/sensor_config.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <regex>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

// A config with mirrors, virtual cameras and awkward doubles in every field.
SensorConfig RichConfig() {
  SensorConfig c;
  std::mt19937 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> jitter(-1e-3, 1e-3);
  c.camera.intrinsics.fx += jitter(rng);
  c.camera.intrinsics.distortion = {-0.1 / 3.0, 1e-17, jitter(rng), jitter(rng), 0.0};
  c.camera.sensor_from_cam.linear() =
      Eigen::AngleAxisd(0.01 + jitter(rng), Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (int i = 0; i < 4; ++i) {
    MirrorConfig m;
    m.name = "mirror_" + std::to_string(i + 1);
    m.surface.center = Eigen::Vector3d(jitter(rng), 1.0 / 3.0, -20.0 + jitter(rng));
    m.surface.u_axis = Eigen::Vector3d(1, 0, 1).normalized();
    m.surface.v_axis = Eigen::Vector3d::UnitY();
    m.surface.half_u = 7.123456789012345;
    m.surface.half_v = 20.0 + jitter(rng);
    c.mirrors.push_back(m);
  }
  for (ImageHalf half : kImageHalves) {
    VirtualCameraConfig v;
    v.name = half == ImageHalf::kLeft ? "vcam_left" : "vcam_right";
    v.half = half;
    v.sensor_from_vcam = c.camera.sensor_from_cam;
    v.intrinsics = c.camera.intrinsics;
    v.column_begin = half == ImageHalf::kLeft ? 0 : 320;
    v.column_end = v.column_begin + 320;
    c.virtual_cameras.push_back(v);
  }
  c.elastic_body.poisson_ratio = 0.4999999;
  c.elastic_body.lateral_face = LateralFace::kFixed;
  return c;
}

void ExpectSame(const Rigid3& a, const Rigid3& b) {
  EXPECT_TRUE(a.matrix() == b.matrix()) << a.matrix() << "\nvs\n" << b.matrix();
}

TEST(SensorConfig, DefaultIsValidAndIsThePrototype) {
  const SensorConfig c;
  EXPECT_NO_THROW(c.Validate());
  EXPECT_EQ(c.markers.rows * c.markers.cols, 400);
  EXPECT_DOUBLE_EQ(c.light_path.h_mm, 40.0);
  EXPECT_DOUBLE_EQ(c.camera.horizontal_fov_deg, 48.0);
  EXPECT_DOUBLE_EQ(c.elastic_body.poisson_ratio, 0.48);
}

TEST(SensorConfig, RoundTripIsExact) {
  const SensorConfig c = RichConfig();
  const std::string yaml = SensorConfigToYaml(c);
  const SensorConfig back = ParseSensorConfig(yaml);
  EXPECT_EQ(SensorConfigToYaml(back), yaml);
  EXPECT_EQ(back.camera.intrinsics, c.camera.intrinsics);
  ExpectSame(back.camera.sensor_from_cam, c.camera.sensor_from_cam);
  ASSERT_EQ(back.mirrors.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(back.mirrors[i].name, c.mirrors[i].name);
    EXPECT_TRUE(back.mirrors[i].surface.center == c.mirrors[i].surface.center);
    EXPECT_EQ(back.mirrors[i].surface.half_v, c.mirrors[i].surface.half_v);
  }
  ASSERT_EQ(back.virtual_cameras.size(), 2u);
  EXPECT_EQ(back.virtual_cameras[1].half, ImageHalf::kRight);
  EXPECT_EQ(back.virtual_cameras[1].column_begin, 320);
  ExpectSame(back.virtual_cameras[0].sensor_from_vcam, c.virtual_cameras[0].sensor_from_vcam);
  EXPECT_EQ(back.elastic_body.poisson_ratio, c.elastic_body.poisson_ratio);
  EXPECT_EQ(back.elastic_body.lateral_face, LateralFace::kFixed);
}

TEST(SensorConfig, SaveAndLoadFile) {
  const SensorConfig c = RichConfig();
  const std::string path = testing::MakeTempDir("config") + "/sensor.yaml";
  SaveSensorConfig(c, path);
  EXPECT_EQ(SensorConfigToYaml(LoadSensorConfig(path)), SensorConfigToYaml(c));
}

// Edits one line of the default config's YAML and expects the error to name `expected`.
void ExpectRefused(const std::string& pattern, const std::string& replacement,
                   const std::string& expected) {
  const std::string yaml = SensorConfigToYaml(SensorConfig{});
  const std::string edited = std::regex_replace(yaml, std::regex(pattern), replacement);
  ASSERT_NE(edited, yaml) << "pattern " << pattern << " not found";
  try {
    ParseSensorConfig(edited, "test.yaml");
    FAIL() << "accepted: " << replacement;
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(expected));
    EXPECT_THAT(e.what(), HasSubstr("test.yaml"));
  }
}

TEST(SensorConfig, RefusesMissingKeys) {
  ExpectRefused("  thickness_mm: 8.0\n", "", "elastic_body.thickness_mm: missing");
  ExpectRefused("  pitch_mm: [^\n]*\n", "", "markers.pitch_mm: missing");
  ExpectRefused("glass:\n", "glas:\n", "glass: missing");
}

TEST(SensorConfig, RefusesUnknownKeysAndBadTypes) {
  ExpectRefused("  rows: 20", "  rows: 20\n  colour: red", "markers.colour: unknown key");
  ExpectRefused("  pitch_mm: [^\n]*", "  pitch_mm: wide", "markers.pitch_mm: 'wide' is not a number");
  ExpectRefused("  rows: 20", "  rows: 2.5", "markers.rows: must be an integer");
  ExpectRefused("lateral_face: free", "lateral_face: loose", "must be free or fixed");
}

TEST(SensorConfig, RefusesOutOfRangeValues) {
  ExpectRefused("  thickness_mm: 8.0", "  thickness_mm: -1.0", "elastic_body.thickness_mm");
  ExpectRefused("  thickness_mm: 2.0", "  thickness_mm: -2.0", "glass.thickness_mm");
  ExpectRefused("horizontal_fov_deg: 48.0", "horizontal_fov_deg: 180.0", "in (0, 180)");
  ExpectRefused("  fov_deg: 48.0\n", "  fov_deg: 190.0\n", "light_path.fov_deg");
  ExpectRefused("poisson_ratio: 0.48", "poisson_ratio: 0.5", "elastic_body.poisson_ratio");
  ExpectRefused("youngs_modulus_mpa: 1.0", "youngs_modulus_mpa: 0.0", "youngs_modulus_mpa");
  ExpectRefused("dot_diameter_mm: 0.6", "dot_diameter_mm: 1.5", "markers.dot_diameter_mm");
  // A k1 of 1e160 was accepted and the distortion silently dropped (no pixel undistorts).
  ExpectRefused("distortion: \\[[^\\]]*\\]", "distortion: [1e160, 0, 0, 0, 0]",
                "camera.distortion [1e+160, 0, 0, 0, 0] is not one-to-one over the image: pixel (0, 0) "
                "does not undistort");
  ExpectRefused("distortion: \\[[^\\]]*\\]", "distortion: [-5, 0, 0, 0, 0]", "is not one-to-one over the image");
}

TEST(SensorConfig, RefusesAMarkerGridLargerThanTheFingertip) {
  ExpectRefused("  rows: 20", "  rows: 40", "beyond the fingertip");
  ExpectRefused("  pitch_mm: 1.27", "  pitch_mm: 2.5", "beyond the fingertip");
}

TEST(SensorConfig, RefusesBadFilesClearly) {
  EXPECT_THROW(LoadSensorConfig("/nonexistent/sensor.yaml"), Error);
  EXPECT_THROW(ParseSensorConfig("camera: [1, 2", "x.yaml"), Error);
  EXPECT_THROW(ParseSensorConfig("", "x.yaml"), Error);
  EXPECT_THROW(ParseSensorConfig("- 1\n- 2\n", "x.yaml"), Error);
}

// Issue 14, defect 3: NaN and infinity in position vectors were accepted.
TEST(SensorConfig, RefusesNonFiniteNumbersAnywhere) {
  ExpectRefused("position_mm: \\[0.0, 0.0, -40.0\\]", "position_mm: [.nan, 0.0, -40.0]",
                "camera.sensor_from_cam.position_mm[0]: '.nan' is not a finite number");
  ExpectRefused("position_mm: \\[0.0, 0.0, -40.0\\]", "position_mm: [0.0, .inf, -40.0]",
                "'.inf' is not a finite number");
  ExpectRefused("youngs_modulus_mpa: 1.0", "youngs_modulus_mpa: .nan", "is not a finite number");
  // A config built in code (a calibration gone wrong) is refused too, and is never saved.
  SensorConfig c = RichConfig();
  c.mirrors[2].surface.center.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(c.Validate(), Error);
  const std::string path = testing::MakeTempDir("nan") + "/sensor.yaml";
  EXPECT_THROW(SaveSensorConfig(c, path), Error);
  EXPECT_FALSE(std::filesystem::exists(path));
  c = RichConfig();
  c.virtual_cameras[1].sensor_from_vcam.translation().z() = std::numeric_limits<double>::infinity();
  EXPECT_THROW(c.Validate(), Error);
}

// Issue 14, defect 4: a duplicated key (the first won) and a second document (ignored).
TEST(SensorConfig, RefusesDuplicateKeysAndSecondDocumentsNamingTheLine) {
  const std::string yaml = SensorConfigToYaml(SensorConfig{});
  const std::string duplicated = std::regex_replace(yaml, std::regex("  rows: 20\n"), "  rows: 20\n  rows: 10\n");
  ASSERT_NE(duplicated, yaml);
  const int line = 1 + static_cast<int>(std::count(yaml.begin(), yaml.begin() + yaml.find("  rows: 20"), '\n'));
  try {
    ParseSensorConfig(duplicated, "dup.yaml");
    FAIL() << "a duplicated key was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              fmt::format("dup.yaml: line {}: duplicated key 'rows' (first at line {})", line + 1, line));
  }
  const int lines = static_cast<int>(std::count(yaml.begin(), yaml.end(), '\n'));
  try {
    ParseSensorConfig(yaml + "---\nmarkers:\n  rows: 10\n", "two.yaml");
    FAIL() << "a second document was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              fmt::format("two.yaml: line {}: a second YAML document; the file must hold one",
                          lines + 1));  // the line of its "---"
  }
  EXPECT_NO_THROW(ParseSensorConfig(yaml + "...\n", "end.yaml"));  // an explicit end is fine
  // yaml-cpp 0.7's LoadAll loops allocating without end on a stray ',' (issue 1040): refused.
  EXPECT_THROW(ParseSensorConfig(",\n", "comma.yaml"), Error);
  EXPECT_THROW(ParseSensorConfig(yaml + "---\n,\n", "comma.yaml"), Error);
}

// Issue 14, defects 5 and 7: sizes without an upper bound hung or died in bad_alloc.
TEST(SensorConfig, RefusesValuesBeyondTheDocumentedLimits) {
  ExpectRefused("  width: 640", "  width: 2000000000", "camera.width = 2000000000 is out of range");
  ExpectRefused("  width: 640", "  width: 2000000000", "<= 8192");
  ExpectRefused("  rows: 20\n  cols: 20", "  rows: 10000\n  cols: 10000", "markers.rows = 10000 is out of range");
  ExpectRefused("youngs_modulus_mpa: 1.0", "youngs_modulus_mpa: 1e300", "<= 1000 MPa");
  ExpectRefused("outer_radius_mm: 45.0", "outer_radius_mm: 1e300", "elastic_body.outer_radius_mm");
  ExpectRefused("  d_mm: 8.0", "  d_mm: 1e9", "light_path.d_mm = 1000000000 is out of range");
  ExpectRefused("refractive_index: 1.41", "refractive_index: 1e9", "elastic_body.refractive_index");
}

TEST(SensorConfig, RefusesAFolderAndADeviceAsAFile) {
  const std::string dir = testing::MakeTempDir("folder");
  try {
    LoadSensorConfig(dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), fmt::format("sensor config '{}' is a directory, not a file", dir));
  }
  EXPECT_THROW(LoadSensorConfig("/dev/zero"), Error);
}

TEST(SensorConfig, MarkersLieOnTheInnerSphereRowMajor) {
  const SensorConfig c;
  const auto p = c.MarkerPositions();
  ASSERT_EQ(p.size(), 400u);
  const double radius = c.elastic_body.outer_radius_mm - c.markers.depth_mm;
  for (const auto& m : p) EXPECT_NEAR((m - c.SphereCenter()).norm(), radius, 1e-12);
  // Column index runs along x, row index along y.
  EXPECT_NEAR(p[1].x() - p[0].x(), c.markers.pitch_mm, 1e-12);
  EXPECT_NEAR(p[20].y() - p[0].y(), c.markers.pitch_mm, 1e-12);
  EXPECT_NEAR(p[0].x(), -9.5 * c.markers.pitch_mm, 1e-12);
}

TEST(SensorConfig, OpticalLayoutNeedsMirrors) {
  EXPECT_THROW(SensorConfig{}.MakeOpticalLayout(), Error);
}

}  // namespace
}  // namespace tac3d
