#include "tac3d/design/light_path_drawing.h"

#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

cv::Scalar ToBgr(const std::string& hex) {
  const unsigned value = std::stoul(hex.substr(1), nullptr, 16);
  return cv::Scalar(value & 0xff, (value >> 8) & 0xff, (value >> 16) & 0xff);
}

}  // namespace

void LightPathDrawing::Add(std::vector<Eigen::Vector2d> points, std::string colour,
                           double width_mm, bool closed, bool dashed) {
  for (const auto& p : points) {
    min_ = min_.cwiseMin(p);
    max_ = max_.cwiseMax(p);
  }
  shapes_.push_back({std::move(points), std::move(colour), width_mm, closed, dashed});
}

LightPathDrawing::LightPathDrawing(const LightPathRoot& r, const SensorConfig& config)
    : min_(Eigen::Vector2d::Constant(1e9)), max_(Eigen::Vector2d::Constant(-1e9)) {
  // The glass plate and the elastic body's outline (its outer surface is a sphere).
  const double half_l = 0.5 * config.elastic_body.base_diameter_mm;
  const double glass = config.glass.thickness_mm;
  Add({{-half_l, -glass}, {half_l, -glass}, {half_l, 0}, {-half_l, 0}}, "#9ecae1", 0.2, true);
  std::vector<Eigen::Vector2d> dome = {{-half_l, 0}};
  const double radius = config.elastic_body.outer_radius_mm;
  const double zc = config.SphereCenter().z();
  for (int i = 0; i <= 64; ++i) {
    const double x = -half_l + 2 * half_l * i / 64.0;
    dome.emplace_back(x, zc + std::sqrt(radius * radius - x * x));
  }
  dome.emplace_back(half_l, 0);
  Add(dome, "#fdae6b", 0.3, true);

  // Mirrors, beams and sight lines, left half then its mirror image.
  for (int side = 0; side < 2; ++side) {
    auto p = [side](const Eigen::Vector2d& q) { return side == 0 ? q : MirrorX(q); };
    Add({p(r.a1), p(r.b1)}, "#252525", 0.8);
    Add({p(r.b2), p(r.a2)}, "#252525", 0.8);
    Add({p(r.camera), p(r.a2), p(r.a1), p(r.a0)}, "#d62728", 0.25);
    Add({p(r.camera), p(r.b2), p(r.b1), p(r.b0)}, "#1f77b4", 0.25);
    Add({p(r.virtual_camera), p(r.center)}, "#2ca02c", 0.2, false, true);
    Add({p(r.virtual_camera), p(r.a0)}, "#2ca02c", 0.12, false, true);
    Add({p(r.virtual_camera), p(r.b0)}, "#2ca02c", 0.12, false, true);
    labels_.push_back({p(r.virtual_camera), side == 0 ? "O'" : "O''"});
    labels_.push_back({p(r.a1), side == 0 ? "A1" : ""});
    labels_.push_back({p(r.b1), side == 0 ? "B1" : ""});
    labels_.push_back({p(r.a2), side == 0 ? "A2" : ""});
  }
  labels_.push_back({r.camera, "O"});
  labels_.push_back({r.b2, "B2"});
  labels_.push_back({r.center, "M"});
  labels_.push_back({{min_.x(), max_.y() + 4},
                     fmt::format("h = {} mm, l = {} mm, d = {} mm, FOV = {} deg, parallax {:.6f} deg",
                                 config.light_path.h_mm, config.light_path.l_mm,
                                 config.light_path.d_mm, config.light_path.fov_deg,
                                 r.parallax_deg)});
  max_.y() += 6;
  min_ -= Eigen::Vector2d::Constant(4);
  max_ += Eigen::Vector2d::Constant(4);
}

std::string LightPathDrawing::ToSvg() const {
  // SVG's y runs down: flip z.
  const Eigen::Vector2d size = max_ - min_;
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"{:.3f} {:.3f} {:.3f} {:.3f}\" "
      "width=\"{:.0f}mm\" height=\"{:.0f}mm\">\n<rect x=\"{:.3f}\" y=\"{:.3f}\" width=\"{:.3f}\" "
      "height=\"{:.3f}\" fill=\"white\"/>\n",
      min_.x(), -max_.y(), size.x(), size.y(), size.x(), size.y(), min_.x(), -max_.y(), size.x(),
      size.y());
  for (const Shape& s : shapes_) {
    std::string points;
    for (const auto& p : s.points) points += fmt::format("{:.4f},{:.4f} ", p.x(), -p.y());
    svg += fmt::format(
        "<{} points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"{}/>\n",
        s.closed ? "polygon" : "polyline", points, s.colour, s.width_mm,
        s.dashed ? " stroke-dasharray=\"1,0.6\"" : "");
  }
  for (const Label& l : labels_) {
    if (l.text.empty()) continue;
    svg += fmt::format("<text x=\"{:.3f}\" y=\"{:.3f}\" font-size=\"2.2\" font-family=\"sans-serif\">{}</text>\n",
                       l.at.x() + 0.8, -l.at.y() - 0.8, l.text);
  }
  return svg + "</svg>\n";
}

void LightPathDrawing::WriteSvg(const std::string& path) const {
  WriteTextFileAtomically(path, ToSvg());
}

void LightPathDrawing::WritePng(const std::string& path, int width_px) const {
  const Eigen::Vector2d size = max_ - min_;
  const double scale = width_px / size.x();
  cv::Mat image(static_cast<int>(std::ceil(size.y() * scale)), width_px, CV_8UC3,
                cv::Scalar(255, 255, 255));
  auto to_px = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() - min_.x()) * scale)),
                     static_cast<int>(std::lround((max_.y() - p.y()) * scale)));
  };
  for (const Shape& s : shapes_) {
    const int thickness = std::max(1, static_cast<int>(std::lround(s.width_mm * scale)));
    const size_t n = s.points.size();
    for (size_t i = 0; i + 1 < n + (s.closed ? 1 : 0); ++i) {
      const Eigen::Vector2d a = s.points[i], b = s.points[(i + 1) % n];
      if (!s.dashed) {
        cv::line(image, to_px(a), to_px(b), ToBgr(s.colour), thickness, cv::LINE_AA);
        continue;
      }
      const int dashes = std::max(1, static_cast<int>((b - a).norm() / 1.6));
      for (int k = 0; k < dashes; ++k) {
        const Eigen::Vector2d p0 = a + (b - a) * (k / static_cast<double>(dashes));
        const Eigen::Vector2d p1 = a + (b - a) * ((k + 0.6) / dashes);
        cv::line(image, to_px(p0), to_px(p1), ToBgr(s.colour), thickness, cv::LINE_AA);
      }
    }
  }
  for (const Label& l : labels_) {
    if (l.text.empty()) continue;
    cv::putText(image, l.text, to_px(l.at + Eigen::Vector2d(0.8, 0.8)), cv::FONT_HERSHEY_SIMPLEX,
                0.5 * width_px / 1200.0, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", image, png)) throw Error(fmt::format("cannot encode '{}' as PNG", path));
  WriteTextFileAtomically(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace tac3d
