#include "tac3d/friction/friction_output.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/scene/ply.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::friction {
namespace {

using ::testing::HasSubstr;

// A flat 4 x 3 mm grid in z = 0 with four bands along x: mu 0.3 (x < 1), 0.65 (x < 2),
// 0.95 (x < 3) and unknown beyond.
FrictionMapResult BandedSheet() {
  FrictionMapResult map;
  const int nx = 41, ny = 31;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = 0.1 * i, y = 0.1 * j;
      map.vertices_mm.emplace_back(x, y, 0.0);
      map.vertex_normals.emplace_back(0, 0, 1);
      const double mu = x < 1 ? 0.3 : x < 2 ? 0.65 : x < 3 ? 0.95 : std::nan("");
      map.mu.push_back(mu);
      map.confidence.push_back(std::isnan(mu) ? 0.0 : 0.5 + x);
      map.slip_count.push_back(std::isnan(mu) ? 0 : 1 + i % 7);
    }
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i;
      map.triangles.emplace_back(a, a + 1, a + nx + 1);
      map.triangles.emplace_back(a, a + nx + 1, a + nx);
    }
  }
  map.slip_points.push_back({Eigen::Vector3d(0.5, 1.25, 0.0), 0.31, 0.07, 0.25, 12, 210});
  map.slip_points.push_back({Eigen::Vector3d(2.5, -1.0, 0.001), 0.93, 0.05, 0.2, 13, 7});
  return map;
}

TEST(FrictionBand, PaperBands) {
  EXPECT_EQ(BandOf(0.0), FrictionBand::kLow);
  EXPECT_EQ(BandOf(0.5), FrictionBand::kLow);
  EXPECT_EQ(BandOf(0.5001), FrictionBand::kMedium);
  EXPECT_EQ(BandOf(0.8), FrictionBand::kMedium);
  EXPECT_EQ(BandOf(0.8001), FrictionBand::kHigh);
  EXPECT_EQ(BandOf(std::nan("")), FrictionBand::kUnknown);
  // Blue, green, red, grey: the dominant channel.
  EXPECT_GT(BandColorRgb(FrictionBand::kLow)[2], 200);
  EXPECT_GT(BandColorRgb(FrictionBand::kMedium)[1], 150);
  EXPECT_GT(BandColorRgb(FrictionBand::kHigh)[0], 200);
  const auto grey = BandColorRgb(FrictionBand::kUnknown);
  EXPECT_TRUE(grey[0] == grey[1] && grey[1] == grey[2]);
}

TEST(WriteFrictionMapPly, BinaryWithMuConfidenceSlipCountAndColoursReadsBack) {
  const FrictionMapResult map = BandedSheet();
  const std::string path = tac3d::testing::MakeTempDir("friction_output") + "/map.ply";
  WriteFrictionMapPly(map, path);
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(bytes, HasSubstr("format binary_little_endian 1.0\n"));
  EXPECT_THAT(bytes,
              HasSubstr("property float x\nproperty float y\nproperty float z\nproperty float mu\n"
                        "property float confidence\nproperty int slip_count\nproperty uchar red\n"
                        "property uchar green\nproperty uchar blue\n"));
  const TriangleMesh mesh = ReadPly(path);
  ASSERT_EQ(mesh.vertices.size(), map.vertices_mm.size());
  ASSERT_EQ(mesh.triangles.size(), map.triangles.size());
  EXPECT_EQ(mesh.triangles[5], map.triangles[5]);
  const auto& mu = mesh.vertex_properties.at("mu");
  for (size_t v = 0; v < map.vertices_mm.size(); ++v) {
    EXPECT_NEAR(mesh.vertices[v].x(), map.vertices_mm[v].x(), 1e-6);
    if (std::isnan(map.mu[v])) {
      EXPECT_TRUE(std::isnan(mu[v]));
    } else {
      EXPECT_FLOAT_EQ(static_cast<float>(mu[v]), static_cast<float>(map.mu[v]));
    }
    EXPECT_EQ(mesh.vertex_properties.at("slip_count")[v], map.slip_count[v]);
    EXPECT_FLOAT_EQ(static_cast<float>(mesh.vertex_properties.at("confidence")[v]),
                    static_cast<float>(map.confidence[v]));
    const auto rgb = BandColorRgb(BandOf(map.mu[v]));
    EXPECT_EQ(mesh.vertex_properties.at("red")[v], rgb[0]);
    EXPECT_EQ(mesh.vertex_properties.at("green")[v], rgb[1]);
    EXPECT_EQ(mesh.vertex_properties.at("blue")[v], rgb[2]);
  }
}

TEST(WriteSlipPointsCsv, OneLineAPoint) {
  const std::string path = tac3d::testing::MakeTempDir("friction_output") + "/slips.csv";
  WriteSlipPointsCsv(BandedSheet().slip_points, path);
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text,
            "x_mm,y_mm,z_mm,mu,normal_force_n,motion_mm,frame,marker\n"
            "0.5,1.25,0,0.31,0.07,0.25,12,210\n"
            "2.5,-1,0.001,0.93,0.05,0.2,13,7\n");
  EXPECT_THROW(WriteSlipPointsCsv({}, "/nonexistent/dir/slips.csv"), Error);
}

TEST(WriteFrictionMapPng, BandColoursFromAbove) {
  const FrictionMapResult map = BandedSheet();
  const std::string path = tac3d::testing::MakeTempDir("friction_output") + "/map.png";
  RenderOptions options;
  options.width = 400;
  options.height = 300;
  options.ambient = 0.3;
  options.annotate = false;  // the mesh alone fills the image
  const RenderSummary summary = WriteFrictionMapPng(map, path, options);
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 400);
  EXPECT_EQ(image.rows, 300);
  // Seen from above, the 4 x 3 sheet fills 90% of the 400 x 300 image: four equal bands.
  EXPECT_NEAR(summary.covered_pixels, 360 * 270, 0.02 * 360 * 270);
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(summary.band_pixels[k], 90 * 270, 0.08 * 90 * 270) << "band " << k;
  // Facing the viewer, shading is full: pixels are the band colours. x grows to the right.
  const auto expect_band = [&](int x, FrictionBand band) {
    const auto rgb = BandColorRgb(band);
    const cv::Vec3b bgr = image.at<cv::Vec3b>(150, x);
    EXPECT_EQ(bgr, cv::Vec3b(rgb[2], rgb[1], rgb[0])) << "column " << x;
  };
  expect_band(60, FrictionBand::kLow);
  expect_band(150, FrictionBand::kMedium);
  expect_band(240, FrictionBand::kHigh);
  expect_band(330, FrictionBand::kUnknown);
  EXPECT_EQ(image.at<cv::Vec3b>(5, 5), cv::Vec3b(255, 255, 255));  // background

  // Tilted 60 deg: Lambert shading darkens to ambient + (1 - ambient) cos 60.
  options.view_direction = Eigen::Vector3d(std::sin(DegToRad(60)), 0, -std::cos(DegToRad(60)));
  options.up = Eigen::Vector3d::UnitY();
  WriteFrictionMapPng(map, path, options);
  const cv::Mat tilted = cv::imread(path, cv::IMREAD_COLOR);
  const double shade = 0.3 + 0.7 * 0.5;
  const cv::Vec3b centre = tilted.at<cv::Vec3b>(150, 200);
  const auto green = BandColorRgb(FrictionBand::kMedium);
  const auto red = BandColorRgb(FrictionBand::kHigh);
  const bool is_green = std::abs(centre[1] - green[1] * shade) <= 1.0;
  const bool is_red = std::abs(centre[2] - red[0] * shade) <= 1.0;
  EXPECT_TRUE(is_green || is_red) << centre;
}

// Annotated: the mesh inside a plot area, the bands left to right as x grows (seen from above,
// the viewer's orientation), a title over it and the colour bar beside it in the band colours.
TEST(WriteFrictionMapPng, AnnotatedWithTitleColourBarAndAxes) {
  const FrictionMapResult map = BandedSheet();
  const std::string path = tac3d::testing::MakeTempDir("friction_output") + "/annotated.png";
  RenderOptions options;
  options.width = 600;
  options.height = 400;
  const RenderSummary summary = WriteFrictionMapPng(map, path, options);
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  // The plot area is 386 x 304 pixels from (64, 40); the 4 x 3 sheet fills 90% of its width.
  EXPECT_NEAR(summary.covered_pixels, 347 * 260, 0.03 * 347 * 260);
  const auto is_band = [&](cv::Point at, FrictionBand band) {
    const auto rgb = BandColorRgb(band);
    return image.at<cv::Vec3b>(at) == cv::Vec3b(rgb[2], rgb[1], rgb[0]);
  };
  const int y = 40 + 304 / 2;
  EXPECT_TRUE(is_band({64 + 386 / 2 - 130, y}, FrictionBand::kLow));
  EXPECT_TRUE(is_band({64 + 386 / 2 + 130, y}, FrictionBand::kUnknown));
  // The colour bar (x 474-496, 1.2 over 240 pixels from y 60): high at the top, low at the
  // bottom.
  EXPECT_TRUE(is_band({485, 70}, FrictionBand::kHigh));
  EXPECT_TRUE(is_band({485, 200}, FrictionBand::kMedium));
  EXPECT_TRUE(is_band({485, 280}, FrictionBand::kLow));
  // Text: dark pixels in the title's strip and under the x axis.
  const auto dark_pixels = [&](cv::Rect r) {
    cv::Mat grey;
    cv::cvtColor(image(r), grey, cv::COLOR_BGR2GRAY);
    return cv::countNonZero(grey < 100);
  };
  EXPECT_GT(dark_pixels({64, 8, 300, 26}), 100);
  EXPECT_GT(dark_pixels({64, 350, 386, 50}), 50);
  options.width = 399;  // too small for the annotations
  EXPECT_THROW(WriteFrictionMapPng(map, path, options), Error);
}

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// Issue 27: the demo wrote no summary.json where `tac3d friction-map` did; both write through
// this function now.
TEST(WriteFrictionMapOutputs, WritesTheFilesAndASummaryOfInputsOptionsAndMap) {
  FrictionMapResult map = BandedSheet();
  map.summary.status = FrictionMapStatus::kOk;
  map.summary.slip_points = 2;
  FrictionMapOptions options;
  options.radius_mm = 1.75;
  const std::string folder = tac3d::testing::MakeTempDir("friction_output") + "/friction_map";
  RenderOptions view;
  view.width = 64;
  view.height = 48;
  view.annotate = false;
  const nlohmann::json returned = WriteFrictionMapOutputs(
      map, options, folder, view, {{"dataset", "slide"}, {"strokes", 3}, {"frames_in", 40}});
  const nlohmann::json summary = ReadJson(folder + "/summary.json");
  EXPECT_EQ(summary, returned);
  EXPECT_EQ(summary.at("dataset"), "slide");
  EXPECT_EQ(summary.at("strokes"), 3);
  EXPECT_EQ(summary.at("frames_in"), 40);
  EXPECT_EQ(summary.at("options").at("radius_mm"), 1.75);
  EXPECT_EQ(summary.at("map").at("status"), ToJson(map.summary).at("status"));
  EXPECT_EQ(summary.at("map").at("slip_points"), 2);
  EXPECT_EQ(summary.at("files").at("png"), folder + "/map.png");
  EXPECT_GT(summary.at("files").at("png_view").at("covered_pixels").get<int>(), 0);
  for (const char* file : {"map.ply", "map.png", "slip_points.csv"}) {
    EXPECT_TRUE(std::ifstream(folder + "/" + file).good()) << file;
  }
  // A map without a mesh still gets its slip points and summary.
  map.triangles.clear();
  const std::string bare = tac3d::testing::MakeTempDir("friction_output") + "/bare";
  WriteFrictionMapOutputs(map, options, bare, view, nlohmann::json::object());
  EXPECT_FALSE(ReadJson(bare + "/summary.json").at("files").contains("png"));
  EXPECT_TRUE(std::ifstream(bare + "/slip_points.csv").good());
}

// Links planted in the output folder, at a file's name, are refused, never written through:
// every file of the map goes through the one output rule.
TEST(WriteFrictionMapOutputs, NeverWritesThroughALinkPlantedInItsFolder) {
  const std::string dir = tac3d::testing::MakeTempDir("friction_links");
  const std::string folder = dir + "/friction_map";
  std::filesystem::create_directories(folder);
  std::ofstream(dir + "/victim.txt") << "keep";
  RenderOptions view;
  view.width = 64;
  view.height = 48;
  view.annotate = false;
  for (const char* file : {"slip_points.csv", "map.ply", "map.png", "summary.json"}) {
    const std::string link = folder + "/" + file;
    std::filesystem::create_symlink(dir + "/victim.txt", link);
    FrictionMapResult map = BandedSheet();
    map.summary.status = FrictionMapStatus::kOk;
    EXPECT_THROW(
        WriteFrictionMapOutputs(map, FrictionMapOptions{}, folder, view, nlohmann::json::object()),
        Error)
        << file;
    std::ifstream victim(dir + "/victim.txt");
    EXPECT_EQ(std::string(std::istreambuf_iterator<char>(victim), {}), "keep") << file;
    std::filesystem::remove(link);
  }
}

TEST(WriteFrictionMapPng, OptionsAndDegenerateMapsThrow) {
  const FrictionMapResult map = BandedSheet();
  const std::string path = tac3d::testing::MakeTempDir("friction_output") + "/bad.png";
  const auto error_of = [&](const std::function<void(RenderOptions&)>& change) -> std::string {
    RenderOptions options;
    change(options);
    try {
      WriteFrictionMapPng(map, path, options);
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  };
  EXPECT_THAT(
      error_of([](auto& o) { o.view_direction.setZero(); }),
      HasSubstr(
          "RenderOptions.view_direction = (0, 0, 0) is out of range: must be finite and non-zero"));
  EXPECT_THAT(error_of([](auto& o) { o.up = Eigen::Vector3d(0, 0, 2); }),
              HasSubstr("RenderOptions.up = (0, 0, 2) is out of range"));
  EXPECT_THAT(error_of([](auto& o) { o.width = 15; }),
              HasSubstr("RenderOptions.width = 15 is out of range: must be in [16, 8192]"));
  EXPECT_THAT(error_of([](auto& o) { o.height = 9000; }), HasSubstr("RenderOptions.height = 9000"));
  EXPECT_THAT(error_of([](auto& o) { o.margin = 0.5; }),
              HasSubstr("RenderOptions.margin = 0.5 is out of range: must be in [0, 0.45]"));
  EXPECT_THAT(error_of([](auto& o) { o.ambient = -0.1; }),
              HasSubstr("RenderOptions.ambient = -0.1 is out of range: must be in [0, 1]"));
  EXPECT_THROW(WriteFrictionMapPng(FrictionMapResult{}, path), Error);
  EXPECT_THROW(WriteFrictionMapPng(map, "/nonexistent/dir/map.png"), Error);
}

}  // namespace
}  // namespace tac3d::friction
