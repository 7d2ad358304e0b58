#include "tac3d/twin/camera_renderer.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/imagefile/grey_image.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A flat dark disk in 3D (a marker, or a dot of the board).
struct Disk {
  Eigen::Vector3d center;
  Eigen::Vector3d normal;  // unit
  double radius_mm;
  double reflectance;      // multiplies what is behind it
};

// Light falloff towards the corners (quadratic in the distance from the image centre),
// with an optional left-to-right tilt of the illumination.
cv::Mat MakeVignette(const CameraIntrinsics& c, const RenderOptions& o) {
  cv::Mat v(c.height, c.width, CV_32FC1);
  const double r2_corner = c.cx * c.cx + c.cy * c.cy;
  for (int y = 0; y < c.height; ++y) {
    float* row = v.ptr<float>(y);
    for (int x = 0; x < c.width; ++x) {
      const double r2 = ((x - c.cx) * (x - c.cx) + (y - c.cy) * (y - c.cy)) / r2_corner;
      const double tilt = 1.0 + o.illumination_tilt * ((x - c.cx) / (c.width - 1));
      row[x] = static_cast<float>((1.0 - o.vignetting * r2) * tilt);
    }
  }
  return v;
}

// Each channel's light relative to the grey render (LedColour), CV_32FC3.
cv::Mat MakeLedColour(const CameraIntrinsics& c, const LedColour& led) {
  cv::Mat field(c.height, c.width, CV_32FC3);
  const double r2_corner = c.cx * c.cx + c.cy * c.cy;
  for (int y = 0; y < c.height; ++y) {
    cv::Vec3f* row = field.ptr<cv::Vec3f>(y);
    for (int x = 0; x < c.width; ++x) {
      const double xn = (x - c.cx) / (c.width - 1), yn = (y - c.cy) / (c.height - 1);
      const double r2 = ((x - c.cx) * (x - c.cx) + (y - c.cy) * (y - c.cy)) / r2_corner;
      for (int ch = 0; ch < 3; ++ch) {
        row[x][ch] = static_cast<float>(
            led.gain[ch] * std::exp(led.x_slope[ch] * xn + led.y_slope[ch] * yn - led.falloff[ch] * r2));
      }
    }
  }
  return field;
}

// Fraction of a unit pixel on the inner side of a straight edge: the pixel centre is at
// signed distance `s` (px, positive outside) from the edge, whose outward unit normal in
// pixel space is `n`. The exact area of a square cut by a line (box-filter
// anti-aliasing), so a dot's image has no sampling pattern and its centroid no bias.
float InsideFraction(float s, const Eigen::Vector2f& n) {
  float a = std::abs(n.x()), b = std::abs(n.y());
  if (a < b) std::swap(a, b);
  const float t = -s;  // how far the centre is inside
  const float corner = 0.5f * (a + b), flat = 0.5f * (a - b);
  if (t <= -corner) return 0.0f;
  if (t >= corner) return 1.0f;
  if (std::abs(t) <= flat) return 0.5f + t / a;
  const float gap = corner - std::abs(t);
  const float tip = gap * gap / (2.0f * a * b);
  return t > 0 ? 1.0f - tip : tip;
}

// Darkens `image` (linear light) by every disk, with each pixel's exact ray: the signed
// distance of the pixel centre's hit to the disk's rim, turned into covered area by the
// local pixel -> disk-plane map.
void SplatDisks(const RayField& rays, const std::vector<Disk>& disks, cv::Mat& image) {
  const PixelOptics& optics = rays.optics();
  const int w = rays.width(), h = rays.height();
  Eigen::Vector3f o, d;
  for (const Disk& disk : disks) {
    const Eigen::Vector3f c = disk.center.cast<float>();
    const Eigen::Vector3f n = disk.normal.cast<float>();
    const Eigen::Vector3f e1 = n.unitOrthogonal();
    const Eigen::Vector3f e2 = n.cross(e1);
    // Where the ray through a pixel point meets the disk's plane, in disk coordinates.
    auto hit = [&](int u, int v, float fu, float fv, Eigen::Vector2f& q) {
      rays.Sample(u, v, fu, fv, o, d);
      const float denom = n.dot(d);
      if (std::abs(denom) < 1e-6f) return false;
      const Eigen::Vector3f p = o + (n.dot(c - o) / denom) * d - c;
      q = {p.dot(e1), p.dot(e2)};
      return true;
    };
    for (ImageHalf half : kImageHalves) {
      const auto centre_px = optics.Project(half, disk.center);
      if (!centre_px) continue;
      const int u0 = static_cast<int>(std::lround(centre_px->x()));
      const int v0 = static_cast<int>(std::lround(centre_px->y()));
      if (u0 < 0 || v0 < 0 || u0 + 1 >= w || v0 + 1 >= h) continue;
      if (!rays.PixelValid(u0, v0) || rays.PixelHalf(u0, v0) != half) continue;
      // The local map pixel -> disk plane: sizes the window and turns distances into px.
      Eigen::Vector2f q00, q10, q01;
      if (!hit(u0, v0, 0.5f, 0.5f, q00) || !hit(u0, v0, 1.5f, 0.5f, q10) ||
          !hit(u0, v0, 0.5f, 1.5f, q01)) {
        continue;
      }
      Eigen::Matrix2f jacobian;
      jacobian << q10 - q00, q01 - q00;
      if (std::abs(jacobian.determinant()) < 1e-12f) continue;
      const Eigen::Matrix2f inverse = jacobian.inverse();
      const float radius = static_cast<float>(disk.radius_mm);
      const int half_u = static_cast<int>(std::ceil(radius * inverse.row(0).norm())) + 2;
      const int half_v = static_cast<int>(std::ceil(radius * inverse.row(1).norm())) + 2;
      const float darkening = static_cast<float>(1.0 - disk.reflectance);
      for (int v = std::max(0, v0 - half_v); v <= std::min(h - 1, v0 + half_v); ++v) {
        float* row = image.ptr<float>(v);
        for (int u = std::max(0, u0 - half_u); u <= std::min(w - 1, u0 + half_u); ++u) {
          if (!rays.PixelValid(u, v) || rays.PixelHalf(u, v) != half) continue;
          Eigen::Vector2f q;
          if (!hit(u, v, 0.5f, 0.5f, q)) continue;
          const float distance = q.norm();
          if (distance < 1e-9f) {
            row[u] *= 1.0f - darkening;
            continue;
          }
          // Gradient of the rim distance in pixel space.
          const Eigen::Vector2f gradient = jacobian.transpose() * (q / distance);
          const float scale = gradient.norm();
          const float coverage =
              InsideFraction((distance - radius) / scale, gradient / scale);
          row[u] *= 1.0f - coverage * darkening;
        }
      }
    }
  }
}

// A session's lighting on linear light: the LEDs' gain and left-to-right gradient (zero at
// the principal point's column, as the illumination tilt), stray light, then the exposure.
void ApplyLighting(const FrameConditions& c, double cx, cv::Mat& image) {
  const int width = image.cols;
  for (int y = 0; y < image.rows; ++y) {
    float* row = image.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      const double light = c.illumination_gain * (1.0 + c.illumination_gradient * (x - cx) / (width - 1));
      row[x] = static_cast<float>(c.exposure * (light * row[x] + c.illumination_offset));
    }
  }
}

// Blur, noise and 8-bit quantisation of linear light (1: full scale), grey or BGR (each
// channel its own noise).
cv::Mat Expose(cv::Mat irradiance, const RenderOptions& o, std::uint64_t frame_index) {
  if (o.blur_sigma_px > 0) cv::GaussianBlur(irradiance, irradiance, cv::Size(0, 0), o.blur_sigma_px);
  cv::Mat dn = irradiance * 255.0;
  if (o.noise) {
    cv::Mat gaussian(dn.size(), dn.type());
    cv::RNG rng(o.seed * 0x9E3779B97F4A7C15ULL + frame_index + 1);
    rng.fill(gaussian, cv::RNG::NORMAL, 0.0, 1.0);
    const float gain = static_cast<float>(o.shot_noise_gain);
    const float read2 = static_cast<float>(o.read_noise_dn * o.read_noise_dn);
    const int values = dn.cols * dn.channels();
    for (int y = 0; y < dn.rows; ++y) {
      float* p = dn.ptr<float>(y);
      const float* g = gaussian.ptr<float>(y);
      for (int x = 0; x < values; ++x) p[x] += std::sqrt(gain * std::max(p[x], 0.0f) + read2) * g[x];
    }
  }
  cv::Mat out;
  dn.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

// A JPEG round trip at `quality` (libjpeg's default 4:2:0 chroma for colour).
cv::Mat CompressJpeg(const cv::Mat& image, int quality) {
  std::vector<std::uint8_t> bytes;
  TAC3D_DEMAND(cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality}));
  cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  TAC3D_DEMAND(decoded.size() == image.size() && decoded.type() == image.type());
  return decoded;
}

// Unit normals of a deformed grid of markers, from its neighbours (central differences
// inside, one-sided at the border), pointing out of the fingertip (+z).
std::vector<Eigen::Vector3d> GridNormals(const std::vector<Eigen::Vector3d>& p, int rows,
                                         int cols) {
  std::vector<Eigen::Vector3d> normals(p.size());
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const int jm = std::max(j - 1, 0), jp = std::min(j + 1, cols - 1);
      const int im = std::max(i - 1, 0), ip = std::min(i + 1, rows - 1);
      const Eigen::Vector3d along_x = p[i * cols + jp] - p[i * cols + jm];
      const Eigen::Vector3d along_y = p[ip * cols + j] - p[im * cols + j];
      Eigen::Vector3d n = along_x.cross(along_y);
      if (n.norm() < 1e-12) n = Eigen::Vector3d::UnitZ();
      normals[i * cols + j] = n.normalized();
    }
  }
  return normals;
}

}  // namespace

bool LedColour::IsWhite() const {
  return gain.isOnes() && x_slope.isZero(0) && y_slope.isZero(0) && falloff.isZero(0);
}

LedColour LedColour::GelSightMini() {
  // Fitted to the film of mini_example.avi (B, G, R; docs/render.md, "Real-image nuisances"),
  // over the twin's own vignetting; the gains' luma is 1, so the grey level stays the twin's.
  LedColour led;
  led.gain = {1.265, 0.992, 0.915};
  led.x_slope = {0.007, -0.027, -0.070};
  led.y_slope = {-0.344, 0.052, 1.399};
  led.falloff = {0.621, 0.399, 1.501};
  return led;
}

RenderOptions RenderOptions::WithRealImageNuisances() const {
  // The levels measured on the GelSight Mini video: docs/render.md, "Real-image nuisances".
  RenderOptions o = *this;
  o.led_colour = LedColour::GelSightMini();
  o.blur_sigma_px = 1.0;
  o.jpeg_quality = 85;
  return o;
}

void RenderOptions::Validate() const {
  const OptionCheck require("render options");
  const LedColour& led = led_colour;
  require(led.gain.allFinite() && led.gain.minCoeff() > 0 && led.gain.maxCoeff() <= 4,
          "led_colour.gain", "each in (0, 4]", led.gain.allFinite() ? led.gain.minCoeff() : NAN);
  for (const auto& [slope, field] : {std::pair{&led.x_slope, "led_colour.x_slope"},
                                     std::pair{&led.y_slope, "led_colour.y_slope"}}) {
    require(slope->allFinite() && slope->cwiseAbs().maxCoeff() <= 5, field, "each in [-5, 5]",
            slope->cwiseAbs().maxCoeff());
  }
  require(led.falloff.allFinite() && led.falloff.minCoeff() >= 0 && led.falloff.maxCoeff() <= 5,
          "led_colour.falloff", "each in [0, 5]",
          led.falloff.minCoeff() < 0 ? led.falloff.minCoeff() : led.falloff.maxCoeff());
  require(jpeg_quality >= 0 && jpeg_quality <= 100, "jpeg_quality", "in [0, 100] (0: none)",
          jpeg_quality);
  require(film_level > 0 && film_level <= 1, "film_level", "in (0, 1]", film_level);
  require(dot_reflectance >= 0 && dot_reflectance < 1, "dot_reflectance", "in [0, 1)", dot_reflectance);
  require(board_level > 0 && board_level <= 1, "board_level", "in (0, 1]", board_level);
  require(board_dot_reflectance >= 0 && board_dot_reflectance < 1, "board_dot_reflectance",
          "in [0, 1)", board_dot_reflectance);
  require(outside_level >= 0 && outside_level <= 1, "outside_level", "in [0, 1]", outside_level);
  require(blur_sigma_px >= 0 && blur_sigma_px <= 10, "blur_sigma_px", "in [0, 10]", blur_sigma_px);
  require(vignetting >= 0 && vignetting < 1, "vignetting", "in [0, 1)", vignetting);
  require(std::abs(illumination_tilt) < 1, "illumination_tilt", "in (-1, 1)", illumination_tilt);
  // Noise beyond the 8-bit range is no camera's, and 1e300 squared is infinite.
  require(shot_noise_gain >= 0 && shot_noise_gain <= 255, "shot_noise_gain", "in [0, 255]",
          shot_noise_gain);
  require(read_noise_dn >= 0 && read_noise_dn <= 255, "read_noise_dn", "in [0, 255] DN",
          read_noise_dn);
}

void DotBoard::Validate() const {
  grid.Validate();
  if (!(margin_mm >= 0)) throw Error(fmt::format("dot board: margin_mm = {} must be >= 0", margin_mm));
}

Eigen::Vector2d DotBoard::Min() const {
  return Eigen::Vector2d::Constant(-margin_mm - 0.5 * grid.dot_diameter_mm);
}

Eigen::Vector2d DotBoard::Max() const {
  return 2 * grid.GridCenter().head<2>() + Eigen::Vector2d::Constant(margin_mm + 0.5 * grid.dot_diameter_mm);
}

Rigid3 DotBoard::SensorFromBoard(const Eigen::Vector3d& centre_in_sensor,
                                 const Eigen::Vector3d& rotation_vector_deg) const {
  const Eigen::Vector2d centre = 0.5 * (Min() + Max());
  const double angle = DegToRad(rotation_vector_deg.norm());
  Rigid3 pose = Rigid3::Identity();
  if (angle > 0) {
    pose.linear() = Eigen::AngleAxisd(angle, rotation_vector_deg.normalized()).toRotationMatrix();
  }
  pose.translation() = centre_in_sensor - pose.linear() * Eigen::Vector3d(centre.x(), centre.y(), 0);
  return pose;
}

MarkerImageRenderer::MarkerImageRenderer(const SensorConfig& config, const RenderOptions& options)
    : config_(config), options_(options), rays_((options.Validate(), MakeMarkerOptics(config))) {
  // The film is seen where a pixel's ray reaches the marker layer inside the fingertip.
  const cv::Mat vignette = MakeVignette(config.camera.intrinsics, options);
  base_ = cv::Mat(rays_.height(), rays_.width(), CV_32FC1);
  const Eigen::Vector3d center = config.SphereCenter();
  const double radius = config.elastic_body.outer_radius_mm - config.markers.depth_mm;
  const double base_radius = 0.5 * config.elastic_body.base_diameter_mm;
  Eigen::Vector3f o, d;
  for (int v = 0; v < rays_.height(); ++v) {
    for (int u = 0; u < rays_.width(); ++u) {
      float level = static_cast<float>(options.outside_level);
      if (rays_.PixelValid(u, v)) {
        rays_.Sample(u, v, 0.5f, 0.5f, o, d);
        const Eigen::Vector3d od = o.cast<double>() - center, dd = d.cast<double>().normalized();
        const double b = od.dot(dd), disc = b * b - (od.squaredNorm() - radius * radius);
        if (disc > 0) {
          const Eigen::Vector3d p = o.cast<double>() + (-b + std::sqrt(disc)) * dd;
          if (p.head<2>().norm() < base_radius) {
            level = static_cast<float>(options.film_level) * vignette.at<float>(v, u);
          }
        }
      }
      base_.at<float>(v, u) = level;
    }
  }
  if (!options.led_colour.IsWhite()) led_colour_ = MakeLedColour(config.camera.intrinsics, options.led_colour);
}

MarkerImageRenderer::~MarkerImageRenderer() = default;

cv::Mat MarkerImageRenderer::RenderIrradiance(const std::vector<Eigen::Vector3d>& markers,
                                              const FrameConditions& conditions) const {
  const int rows = config_.markers.rows, cols = config_.markers.cols;
  if (static_cast<int>(markers.size()) != rows * cols) {
    throw Error(fmt::format("render: {} marker positions given, the sensor has {} x {}",
                            markers.size(), rows, cols));
  }
  const std::vector<Eigen::Vector3d> normals = GridNormals(markers, rows, cols);
  const double reflectance = 1.0 - conditions.dot_contrast * (1.0 - options_.dot_reflectance);
  std::vector<Disk> disks(markers.size());
  for (size_t i = 0; i < markers.size(); ++i) {
    disks[i] = {markers[i] + conditions.creep_mm, normals[i], 0.5 * config_.markers.dot_diameter_mm,
                reflectance};
  }
  cv::Mat image = base_.clone();
  SplatDisks(rays_, disks, image);
  ApplyLighting(conditions, config_.camera.intrinsics.cx, image);
  return image;
}

cv::Mat MarkerImageRenderer::RenderCamera(const std::vector<Eigen::Vector3d>& markers,
                                          std::uint64_t frame_index,
                                          const FrameConditions& conditions) const {
  cv::Mat irradiance = RenderIrradiance(markers, conditions);
  if (!led_colour_.empty()) {
    cv::Mat grey3;
    cv::merge(std::vector<cv::Mat>(3, irradiance), grey3);
    irradiance = grey3.mul(led_colour_);
  }
  cv::Mat image = Expose(irradiance, options_, frame_index);
  return options_.jpeg_quality > 0 ? CompressJpeg(image, options_.jpeg_quality) : image;
}

cv::Mat MarkerImageRenderer::Render(const std::vector<Eigen::Vector3d>& markers,
                                    std::uint64_t frame_index,
                                    const FrameConditions& conditions) const {
  cv::Mat grey;
  ConvertToGrey(RenderCamera(markers, frame_index, conditions), grey);
  return grey;
}

BoardImageRenderer::BoardImageRenderer(const SensorConfig& config, const RenderOptions& options)
    : config_(config),
      options_(options),
      rays_((options.Validate(), config.MakeOpticalLayout(false))),
      vignette_(MakeVignette(config.camera.intrinsics, options)) {}

cv::Mat BoardImageRenderer::RenderIrradiance(const DotBoard& board,
                                             const Rigid3& sensor_from_board) const {
  board.Validate();
  const Rigid3 board_from_sensor = sensor_from_board.inverse();
  const Eigen::Vector3d n = sensor_from_board.linear().col(2);
  const Eigen::Vector3d c = sensor_from_board.translation();
  const Eigen::Vector2d lo = board.Min(), hi = board.Max();
  cv::Mat image(rays_.height(), rays_.width(), CV_32FC1);
  Eigen::Vector3f o, d;
  for (int v = 0; v < rays_.height(); ++v) {
    float* row = image.ptr<float>(v);
    const float* vig = vignette_.ptr<float>(v);
    for (int u = 0; u < rays_.width(); ++u) {
      float level = static_cast<float>(options_.outside_level);
      if (rays_.PixelValid(u, v)) {
        rays_.Sample(u, v, 0.5f, 0.5f, o, d);
        const Eigen::Vector3d od = o.cast<double>(), dd = d.cast<double>();
        const double denom = n.dot(dd);
        if (std::abs(denom) > 1e-9) {
          const double t = n.dot(c - od) / denom;
          const Eigen::Vector3d p = board_from_sensor * (od + t * dd);
          if (t > 0 && p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y()) {
            level = static_cast<float>(options_.board_level) * vig[u];
          }
        }
      }
      row[u] = level;
    }
  }
  std::vector<Disk> disks;
  for (const Eigen::Vector3d& p : board.grid.DotCenters()) {
    disks.push_back({sensor_from_board * p, n, 0.5 * board.grid.dot_diameter_mm,
                     options_.board_dot_reflectance});
  }
  SplatDisks(rays_, disks, image);
  return image;
}

cv::Mat BoardImageRenderer::Render(const DotBoard& board, const Rigid3& sensor_from_board,
                                   std::uint64_t frame_index) const {
  return Expose(RenderIrradiance(board, sensor_from_board), options_, frame_index);
}

}  // namespace tac3d
