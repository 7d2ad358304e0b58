#include "tac3d/friction/friction_output.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

// Where the mesh is drawn: the whole image, or inside the annotations' title (top), axes
// (left, bottom) and colour bar (right).
cv::Rect PlotArea(const RenderOptions& options) {
  if (!options.annotate) return {0, 0, options.width, options.height};
  constexpr int kLeft = 64, kTop = 40, kRight = 150, kBottom = 56;
  return {kLeft, kTop, options.width - kLeft - kRight, options.height - kTop - kBottom};
}

// The orthographic projection: pixel = offset + scale * (right, down) . p.
struct Projection {
  double scale = 1.0;
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();
};

// The mesh in pixels (x, y) and depth along the view, scaled to fit the plot area's margins.
std::vector<Eigen::Vector3d> Project(const FrictionMapResult& map,
                                     const RenderOptions& options,
                                     const ViewBasis& b,
                                     Projection* projection) {
  const cv::Rect area = PlotArea(options);
  std::vector<Eigen::Vector3d> q(map.vertices_mm.size());
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (size_t i = 0; i < q.size(); ++i) {
    const Eigen::Vector3d& p = map.vertices_mm[i];
    q[i] = Eigen::Vector3d(b.right.dot(p), b.down.dot(p), b.view.dot(p));
    lo = lo.cwiseMin(q[i].head<2>());
    hi = hi.cwiseMax(q[i].head<2>());
  }
  const double usable_w = area.width * (1 - 2 * options.margin);
  const double usable_h = area.height * (1 - 2 * options.margin);
  const Eigen::Vector2d extent = (hi - lo).cwiseMax(1e-9);
  projection->scale = std::min(usable_w / extent.x(), usable_h / extent.y());
  projection->offset = Eigen::Vector2d(area.x + 0.5 * area.width, area.y + 0.5 * area.height) -
                       projection->scale * 0.5 * (lo + hi);
  for (Eigen::Vector3d& v : q) {
    v.x() = projection->offset.x() + projection->scale * v.x();
    v.y() = projection->offset.y() + projection->scale * v.y();
  }
  return q;
}

// A world direction as a label: "x", "-z", or its components when it is no axis.
std::string DirectionName(const Eigen::Vector3d& d) {
  for (int a = 0; a < 3; ++a) {
    if (std::abs(std::abs(d[a]) - 1.0) < 1e-3)
      return fmt::format("{}{}", d[a] < 0 ? "-" : "", "xyz"[a]);
  }
  return fmt::format("({:.2f}, {:.2f}, {:.2f})", d.x(), d.y(), d.z());
}

// A round tick step (1, 2 or 5 times a power of ten) giving about `target` ticks over `span`.
double TickStep(double span, int target) {
  const double raw = span / target, decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * decade >= raw) return m * decade;
  }
  return 10.0 * decade;
}

void PutText(cv::Mat& image, const std::string& text, cv::Point at, double size = 0.45) {
  cv::putText(image, text, at, cv::FONT_HERSHEY_SIMPLEX, size, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
}

// The title, the bands' colour bar with its mu scale, and the mm axes along the image's right
// and up directions (world coordinates of the projection, so the ticks are the mesh's own).
void Annotate(cv::Mat& image,
              const RenderOptions& options,
              const ViewBasis& b,
              const Projection& p) {
  const cv::Rect area = PlotArea(options);
  PutText(image,
          fmt::format("friction map: mu, seen along {}", DirectionName(b.view)),
          cv::Point(area.x, 26),
          0.6);
  // The colour bar: one box a band, mu growing upwards, the band limits as ticks.
  const int bar_x = area.x + area.width + 24, bar_w = 22, bar_top = area.y + 20;
  const int bar_h = std::min(240, area.height - 60);
  PutText(image, "mu", cv::Point(bar_x, bar_top - 8));
  const struct {
    FrictionBand band;
    double from, to;
  } bands[] = {{FrictionBand::kLow, 0.0, 0.5},
               {FrictionBand::kMedium, 0.5, 0.8},
               {FrictionBand::kHigh, 0.8, 1.2}};
  const auto y_of = [&](double mu) {
    return bar_top + bar_h - static_cast<int>(std::lround(mu / 1.2 * bar_h));
  };
  for (const auto& s : bands) {
    const auto rgb = BandColorRgb(s.band);
    cv::rectangle(image,
                  cv::Point(bar_x, y_of(s.to)),
                  cv::Point(bar_x + bar_w, y_of(s.from)),
                  cv::Scalar(rgb[2], rgb[1], rgb[0]),
                  cv::FILLED);
  }
  cv::rectangle(
      image, cv::Point(bar_x, y_of(1.2)), cv::Point(bar_x + bar_w, y_of(0.0)), cv::Scalar(0, 0, 0));
  for (const double mu : {0.0, 0.5, 0.8}) {
    cv::line(image,
             cv::Point(bar_x + bar_w, y_of(mu)),
             cv::Point(bar_x + bar_w + 4, y_of(mu)),
             cv::Scalar(0, 0, 0));
    PutText(image, fmt::format("{:.1f}", mu), cv::Point(bar_x + bar_w + 7, y_of(mu) + 5));
  }
  PutText(image, "> 0.8", cv::Point(bar_x + bar_w + 7, y_of(1.0) + 5));
  const auto unknown = BandColorRgb(FrictionBand::kUnknown);
  const int unknown_y = bar_top + bar_h + 16;
  cv::rectangle(image,
                cv::Point(bar_x, unknown_y),
                cv::Point(bar_x + bar_w, unknown_y + 14),
                cv::Scalar(unknown[2], unknown[1], unknown[0]),
                cv::FILLED);
  PutText(image, "unknown", cv::Point(bar_x + bar_w + 7, unknown_y + 12));
  // Axes: world mm along the image's right (bottom edge) and up (left edge) directions.
  const cv::Scalar black(0, 0, 0);
  const int x_axis_y = area.y + area.height, y_axis_x = area.x;
  cv::line(image, cv::Point(area.x, x_axis_y), cv::Point(area.x + area.width, x_axis_y), black);
  cv::line(image, cv::Point(y_axis_x, area.y), cv::Point(y_axis_x, x_axis_y), black);
  const double x_from = (area.x - p.offset.x()) / p.scale,
               x_to = (area.x + area.width - p.offset.x()) / p.scale;
  const double step_x = TickStep(x_to - x_from, 6);
  for (double v = std::ceil(x_from / step_x) * step_x; v <= x_to; v += step_x) {
    const int x = static_cast<int>(std::lround(p.offset.x() + p.scale * v));
    cv::line(image, cv::Point(x, x_axis_y), cv::Point(x, x_axis_y + 5), black);
    PutText(image,
            fmt::format("{:g}", std::abs(v) < 1e-9 ? 0.0 : v),
            cv::Point(x - 10, x_axis_y + 20),
            0.4);
  }
  PutText(image,
          fmt::format("{} (mm)", DirectionName(b.right)),
          cv::Point(area.x + area.width / 2 - 20, x_axis_y + 44));
  // Up is -down: the tick's value grows upwards.
  const double y_from = -(area.y + area.height - p.offset.y()) / p.scale,
               y_to = -(area.y - p.offset.y()) / p.scale;
  const double step_y = TickStep(y_to - y_from, 5);
  for (double v = std::ceil(y_from / step_y) * step_y; v <= y_to; v += step_y) {
    const int y = static_cast<int>(std::lround(p.offset.y() - p.scale * v));
    cv::line(image, cv::Point(y_axis_x - 5, y), cv::Point(y_axis_x, y), black);
    PutText(image, fmt::format("{:g}", std::abs(v) < 1e-9 ? 0.0 : v), cv::Point(4, y + 5), 0.4);
  }
  PutText(image, fmt::format("{} (mm)", DirectionName(-b.down)), cv::Point(4, area.y - 6), 0.4);
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
  if (annotate && (width < 400 || height < 300)) {
    fail("width x height",
         fmt::format("{} x {}", width, height),
         "at least 400 x 300 when annotated");
  }
}

RenderSummary WriteFrictionMapPng(const FrictionMapResult& map,
                                  const std::string& path,
                                  const RenderOptions& options) {
  options.Validate();
  if (map.triangles.empty())
    throw Error(fmt::format("friction map PNG '{}': the map has no triangle", path));
  TAC3D_DEMAND(map.mu.size() == map.vertices_mm.size());
  const ViewBasis basis = MakeViewBasis(options);
  Projection projection;
  const std::vector<Eigen::Vector3d> q = Project(map, options, basis, &projection);
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
  if (options.annotate) Annotate(image, options, basis, projection);
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
