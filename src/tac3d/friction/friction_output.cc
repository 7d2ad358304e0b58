#include "tac3d/friction/friction_output.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "tac3d/imagefile/image_write.h"
#include "tac3d/scene/ply.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::friction {
namespace {

// Image coordinates of the world: an orthonormal basis (right, down, view) for the view.
struct ViewBasis {
  Eigen::Vector3d right, down, view;
};

ViewBasis MakeViewBasis(const RenderOptions& options) {
  ViewBasis b;
  b.view = options.view_direction.normalized();
  const Eigen::Vector3d up = (options.up - options.up.dot(b.view) * b.view).normalized();
  b.down = -up;
  b.right = b.down.cross(b.view);  // right-handed (right, down, view): image x, image y, depth
  return b;
}

// The mesh in pixels (x, y) and depth along the view, scaled to fit the image's margins.
std::vector<Eigen::Vector3d> Project(const FrictionMapResult& map,
                                     const RenderOptions& options,
                                     const ViewBasis& b) {
  std::vector<Eigen::Vector3d> q(map.vertices_mm.size());
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (size_t i = 0; i < q.size(); ++i) {
    const Eigen::Vector3d& p = map.vertices_mm[i];
    q[i] = Eigen::Vector3d(b.right.dot(p), b.down.dot(p), b.view.dot(p));
    lo = lo.cwiseMin(q[i].head<2>());
    hi = hi.cwiseMax(q[i].head<2>());
  }
  const double usable_w = options.width * (1 - 2 * options.margin);
  const double usable_h = options.height * (1 - 2 * options.margin);
  const Eigen::Vector2d extent = (hi - lo).cwiseMax(1e-9);
  const double scale = std::min(usable_w / extent.x(), usable_h / extent.y());
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  for (Eigen::Vector3d& v : q) {
    v.x() = 0.5 * options.width + scale * (v.x() - centre.x());
    v.y() = 0.5 * options.height + scale * (v.y() - centre.y());
  }
  return q;
}

}  // namespace

FrictionBand BandOf(double mu) {
  if (std::isnan(mu)) return FrictionBand::kUnknown;
  if (mu <= kLowBandMaxMu) return FrictionBand::kLow;
  if (mu <= kMediumBandMaxMu) return FrictionBand::kMedium;
  return FrictionBand::kHigh;
}

std::array<std::uint8_t, 3> BandColorRgb(FrictionBand band) {
  switch (band) {
    case FrictionBand::kLow:
      return {40, 90, 255};
    case FrictionBand::kMedium:
      return {40, 200, 60};
    case FrictionBand::kHigh:
      return {230, 40, 40};
    case FrictionBand::kUnknown:
      break;
  }
  return {150, 150, 150};
}

void WriteFrictionMapPly(const FrictionMapResult& map, const std::string& path) {
  TriangleMesh mesh;
  mesh.vertices = map.vertices_mm;
  mesh.triangles = map.triangles;
  const size_t n = map.vertices_mm.size();
  TAC3D_DEMAND(map.mu.size() == n && map.confidence.size() == n && map.slip_count.size() == n);
  auto& props = mesh.vertex_properties;
  props["mu"] = map.mu;
  props["confidence"] = map.confidence;
  props["slip_count"].assign(map.slip_count.begin(), map.slip_count.end());
  for (const char* c : {"red", "green", "blue"}) props[c].resize(n);
  for (size_t i = 0; i < n; ++i) {
    const auto rgb = BandColorRgb(BandOf(map.mu[i]));
    props["red"][i] = rgb[0];
    props["green"][i] = rgb[1];
    props["blue"][i] = rgb[2];
  }
  PlyWriteOptions options;
  options.format = PlyFormat::kBinaryLittleEndian;
  options.coordinate_type = "float";
  options.property_types = {{"mu", "float"},
                            {"confidence", "float"},
                            {"slip_count", "int"},
                            {"red", "uchar"},
                            {"green", "uchar"},
                            {"blue", "uchar"}};
  options.property_order = {"mu", "confidence", "slip_count", "red", "green", "blue"};
  options.comments = {"tac3d friction map: mm, world frame; mu NaN where unknown",
                      "bands: blue mu <= 0.5, green 0.5-0.8, red > 0.8, grey unknown"};
  WritePly(mesh, path, options);
}

void WriteSlipPointsCsv(const std::vector<SlipPoint>& slip_points, const std::string& path) {
  std::string out = "x_mm,y_mm,z_mm,mu,normal_force_n,motion_mm,frame,marker\n";
  for (const SlipPoint& s : slip_points) {
    out += fmt::format("{},{},{},{},{},{},{},{}\n",
                       s.p_in_world_mm.x(),
                       s.p_in_world_mm.y(),
                       s.p_in_world_mm.z(),
                       s.mu,
                       s.normal_force_n,
                       s.motion_mm,
                       s.frame_index,
                       s.marker);
  }
  WriteTextFileAtomically(path, out);
}

void RenderOptions::Validate() const {
  const auto fail = [](const char* field, const std::string& value, const char* bound) {
    throw Error(
        fmt::format("RenderOptions.{} = {} is out of range: must be {}", field, value, bound));
  };
  if (!view_direction.allFinite() || view_direction.norm() < 1e-9) {
    fail("view_direction",
         fmt::format("({}, {}, {})", view_direction.x(), view_direction.y(), view_direction.z()),
         "finite and non-zero");
  }
  if (!up.allFinite() || up.cross(view_direction.normalized()).norm() < 1e-6 * up.norm() ||
      up.norm() < 1e-9) {
    fail("up",
         fmt::format("({}, {}, {})", up.x(), up.y(), up.z()),
         "finite, non-zero, not along view_direction");
  }
  if (width < 16 || width > 8192) fail("width", std::to_string(width), "in [16, 8192]");
  if (height < 16 || height > 8192) fail("height", std::to_string(height), "in [16, 8192]");
  if (!(margin >= 0 && margin <= 0.45)) fail("margin", fmt::format("{}", margin), "in [0, 0.45]");
  if (!(ambient >= 0 && ambient <= 1)) fail("ambient", fmt::format("{}", ambient), "in [0, 1]");
}

RenderSummary WriteFrictionMapPng(const FrictionMapResult& map,
                                  const std::string& path,
                                  const RenderOptions& options) {
  options.Validate();
  if (map.triangles.empty())
    throw Error(fmt::format("friction map PNG '{}': the map has no triangle", path));
  TAC3D_DEMAND(map.mu.size() == map.vertices_mm.size());
  const ViewBasis basis = MakeViewBasis(options);
  const std::vector<Eigen::Vector3d> q = Project(map, options, basis);
  cv::Mat image(options.height, options.width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat depth(
      options.height, options.width, CV_64F, cv::Scalar(std::numeric_limits<double>::infinity()));
  cv::Mat band(options.height, options.width, CV_8S, cv::Scalar(-1));
  for (const Eigen::Vector3i& t : map.triangles) {
    const Eigen::Vector3d &a = q[t[0]], &b = q[t[1]], &c = q[t[2]];
    const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (std::abs(area) < 1e-12) continue;
    const Eigen::Vector3d pa = map.vertices_mm[t[0]], pb = map.vertices_mm[t[1]],
                          pc = map.vertices_mm[t[2]];
    const double lambert = std::abs((pb - pa).cross(pc - pa).normalized().dot(basis.view));
    const double shade = options.ambient + (1 - options.ambient) * lambert;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x(), b.x(), c.x()}))));
    const int x1 =
        std::min(options.width - 1, static_cast<int>(std::ceil(std::max({a.x(), b.x(), c.x()}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y(), b.y(), c.y()}))));
    const int y1 =
        std::min(options.height - 1, static_cast<int>(std::ceil(std::max({a.y(), b.y(), c.y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        // Barycentric coordinates of the pixel centre.
        const double wa = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) / area;
        const double wb = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) / area;
        const double wc = 1 - wa - wb;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        const double z = wa * a.z() + wb * b.z() + wc * c.z();
        if (z >= depth.at<double>(y, x)) continue;
        depth.at<double>(y, x) = z;
        const int nearest = wa >= wb && wa >= wc ? t[0] : (wb >= wc ? t[1] : t[2]);
        const FrictionBand fb = BandOf(map.mu[nearest]);
        const auto rgb = BandColorRgb(fb);
        band.at<signed char>(y, x) = static_cast<signed char>(fb);
        image.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(rgb[2] * shade),
                                              cv::saturate_cast<uchar>(rgb[1] * shade),
                                              cv::saturate_cast<uchar>(rgb[0] * shade));
      }
    }
  }
  RenderSummary summary;
  for (int y = 0; y < band.rows; ++y) {
    for (int x = 0; x < band.cols; ++x) {
      const int k = band.at<signed char>(y, x);
      if (k < 0) continue;
      ++summary.covered_pixels;
      ++summary.band_pixels[k];
    }
  }
  WriteImageFile(path, image);
  return summary;
}

nlohmann::json WriteFrictionMapFiles(const FrictionMapResult& map,
                                     const std::string& folder,
                                     const RenderOptions& view) {
  MakeDirectory(folder);
  nlohmann::json files = {{"slip_points_csv", folder + "/slip_points.csv"}};
  WriteSlipPointsCsv(map.slip_points, folder + "/slip_points.csv");
  if (map.triangles.empty()) return files;
  WriteFrictionMapPly(map, folder + "/map.ply");
  const RenderSummary r = WriteFrictionMapPng(map, folder + "/map.png", view);
  files["ply"] = folder + "/map.ply";
  files["png"] = folder + "/map.png";
  files["png_view"] = {
      {"view_direction",
       {view.view_direction.x(), view.view_direction.y(), view.view_direction.z()}},
      {"up", {view.up.x(), view.up.y(), view.up.z()}},
      {"covered_pixels", r.covered_pixels},
      {"band_pixels",
       {{"unknown", r.band_pixels[0]},
        {"low", r.band_pixels[1]},
        {"medium", r.band_pixels[2]},
        {"high", r.band_pixels[3]}}}};
  return files;
}

nlohmann::json WriteFrictionMapOutputs(const FrictionMapResult& map,
                                       const FrictionMapOptions& options,
                                       const std::string& folder,
                                       const RenderOptions& view,
                                       nlohmann::json inputs) {
  inputs["options"] = ToJson(options);
  inputs["map"] = ToJson(map.summary);
  inputs["files"] = WriteFrictionMapFiles(map, folder, view);
  WriteTextFileAtomically(folder + "/summary.json", inputs.dump(2) + "\n");
  return inputs;
}

}  // namespace tac3d::friction
