#include "tac3d/sensor/sensor_config.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

constexpr const char* kVendorCameraModelType = "vendor_pinhole_refraction";

// ---- Validation -------------------------------------------------------------------------

void Require(bool ok, const std::string& field, const std::string& bound, double value) {
  if (!ok || std::isnan(value)) {
    throw Error(fmt::format("sensor config: {} = {} is out of range: must be {}", field, value,
                            bound));
  }
}

void ValidateRotation(const Eigen::Matrix3d& r, const std::string& field) {
  if (!(RotationDefect(r) < kRotationTolerance)) {
    throw Error(fmt::format("sensor config: {} is not a rotation (max(|R R^T - I|, |det R - 1|) = {:.3g})",
                            field, RotationDefect(r)));
  }
}

// A length in (0, kMaxLengthMm] mm.
void RequireLength(double value, const std::string& field) {
  Require(value > 0 && value <= SensorLimits::kMaxLengthMm, field,
          fmt::format("> 0 and <= {} mm", SensorLimits::kMaxLengthMm), value);
}

// A position whose coordinates are finite and within kMaxLengthMm of the sensor origin.
void RequirePosition(const Eigen::Vector3d& p, const std::string& field) {
  for (int i = 0; i < 3; ++i) {
    Require(std::abs(p(i)) <= SensorLimits::kMaxLengthMm, fmt::format("{}[{}]", field, i),
            fmt::format("finite, |x| <= {} mm", SensorLimits::kMaxLengthMm), p(i));
  }
}

// The lens model holds where its distortion is one-to-one: every pixel of the image (a 9 x 9
// grid of them, corners included) undistorts to a point that distorts back onto it. Far-off
// coefficients (k1 = 1e160) fail this; tac3d would otherwise triangulate as if the lens had
// no distortion at all.
void RequireInvertibleDistortion(const CameraIntrinsics& c, const std::string& field) {
  constexpr int kSamples = 9;
  for (int i = 0; i < kSamples; ++i) {
    for (int j = 0; j < kSamples; ++j) {
      const Eigen::Vector2d pixel(i * (c.width - 1.0) / (kSamples - 1), j * (c.height - 1.0) / (kSamples - 1));
      const Eigen::Vector2d distorted((pixel.x() - c.cx) / c.fx, (pixel.y() - c.cy) / c.fy);
      const Eigen::Vector2d undistorted = c.Undistort(distorted);
      const Eigen::Vector2d back = c.Distort(undistorted);
      if (!back.allFinite() || !((back - distorted).norm() <= 1e-6 * (1.0 + distorted.norm()))) {
        throw Error(fmt::format(
            "sensor config: {}.distortion [{}, {}, {}, {}, {}] is not one-to-one over the image: pixel ({}, {}) "
            "does not undistort (the coefficients are outside where the lens model holds)",
            field, c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3], c.distortion[4],
            pixel.x(), pixel.y()));
      }
    }
  }
}

void ValidateIntrinsics(const CameraIntrinsics& c, const std::string& field) {
  const std::string side_bound = fmt::format("> 1 and <= {}", SensorLimits::kMaxImageSidePx);
  Require(c.width > 1 && c.width <= SensorLimits::kMaxImageSidePx, field + ".width", side_bound, c.width);
  Require(c.height > 1 && c.height <= SensorLimits::kMaxImageSidePx, field + ".height", side_bound,
          c.height);
  const std::string focal_bound = fmt::format("> 0 and <= {:g} px", SensorLimits::kMaxFocalLengthPx);
  Require(c.fx > 0 && c.fx <= SensorLimits::kMaxFocalLengthPx, field + ".fx", focal_bound, c.fx);
  Require(c.fy > 0 && c.fy <= SensorLimits::kMaxFocalLengthPx, field + ".fy", focal_bound, c.fy);
  Require(c.cx > 0 && c.cx < c.width, field + ".cx", "inside the image (0, width)", c.cx);
  Require(c.cy > 0 && c.cy < c.height, field + ".cy", "inside the image (0, height)", c.cy);
  for (int i = 0; i < 5; ++i) {
    Require(std::isfinite(c.distortion[i]), fmt::format("{}.distortion[{}]", field, i), "finite",
            c.distortion[i]);
  }
  RequireInvertibleDistortion(c, field);
}

void ValidateRectangle(const Rectangle3& r, const std::string& field) {
  RequirePosition(r.center, field + ".center_mm");
  RequireLength(r.half_u, field + ".half_u_mm");
  RequireLength(r.half_v, field + ".half_v_mm");
  const double skew = std::abs(r.u_axis.dot(r.v_axis));
  const double norm_error =
      std::max(std::abs(r.u_axis.norm() - 1.0), std::abs(r.v_axis.norm() - 1.0));
  if (!(skew < 1e-6) || !(norm_error < 1e-6)) {
    throw Error(fmt::format("sensor config: {}: u_axis and v_axis must be orthonormal", field));
  }
}

CameraIntrinsics ReadIntrinsics(YamlReader r) {
  CameraIntrinsics c;
  c.width = r.Int("width");
  c.height = r.Int("height");
  c.fx = r.Double("fx");
  c.fy = r.Double("fy");
  c.cx = r.Double("cx");
  c.cy = r.Double("cy");
  const Eigen::Matrix<double, 5, 1> d = r.Vector<5>("distortion");
  for (int i = 0; i < 5; ++i) c.distortion[i] = d(i);
  return c;
}

Rigid3 ReadPose(YamlReader r) {
  Rigid3 t = Rigid3::Identity();
  t.translation() = r.Vector<3>("position_mm");
  t.linear() = r.Matrix3("rotation");
  return t;
}

Rectangle3 ReadRectangle(YamlReader& r) {
  Rectangle3 rect;
  rect.center = r.Vector<3>("center_mm");
  rect.u_axis = r.Vector<3>("u_axis");
  rect.v_axis = r.Vector<3>("v_axis");
  rect.half_u = r.Double("half_u_mm");
  rect.half_v = r.Double("half_v_mm");
  return rect;
}

// ---- YAML writing with shortest exact doubles ------------------------------------------

std::string ExactDouble(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  std::string s(buffer, result.ptr);
  // Keep it a float to a YAML reader ("1" would also parse, but "1.0" says what it is).
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

class Writer {
 public:
  YAML::Emitter& out() { return out_; }
  void Key(const std::string& k) { out_ << YAML::Key << k << YAML::Value; }
  void Double(const std::string& k, double v) {
    Key(k);
    out_ << ExactDouble(v);
  }
  template <typename Vec>
  void Vector(const std::string& k, const Vec& v) {
    Key(k);
    out_ << YAML::Flow << YAML::BeginSeq;
    for (int i = 0; i < v.size(); ++i) out_ << ExactDouble(v(i));
    out_ << YAML::EndSeq;
  }
  void Matrix3(const std::string& k, const Eigen::Matrix3d& m) {
    Key(k);
    out_ << YAML::BeginSeq;
    for (int r = 0; r < 3; ++r) {
      out_ << YAML::Flow << YAML::BeginSeq;
      for (int c = 0; c < 3; ++c) out_ << ExactDouble(m(r, c));
      out_ << YAML::EndSeq;
    }
    out_ << YAML::EndSeq;
  }
  void Intrinsics(const std::string& k, const CameraIntrinsics& c) {
    Key(k);
    out_ << YAML::BeginMap;
    Key("width");
    out_ << c.width;
    Key("height");
    out_ << c.height;
    Double("fx", c.fx);
    Double("fy", c.fy);
    Double("cx", c.cx);
    Double("cy", c.cy);
    Vector("distortion", Eigen::Map<const Eigen::Matrix<double, 5, 1>>(c.distortion.data()));
    out_ << YAML::EndMap;
  }
  void Pose(const std::string& k, const Rigid3& t) {
    Key(k);
    out_ << YAML::BeginMap;
    Vector("position_mm", t.translation());
    Matrix3("rotation", t.linear());
    out_ << YAML::EndMap;
  }
  void Rectangle(const Rectangle3& r) {
    Vector("center_mm", r.center);
    Vector("u_axis", r.u_axis);
    Vector("v_axis", r.v_axis);
    Double("half_u_mm", r.half_u);
    Double("half_v_mm", r.half_v);
  }

  void VendorCamera(const VendorCameraModelConfig& v) {
    Key("camera_model");
    out_ << YAML::BeginMap;
    Key("type");
    out_ << kVendorCameraModelType;
    Key("serial_number");
    out_ << YAML::DoubleQuoted << v.serial_number;
    Key("image_flip_x");
    out_ << v.image_flip_x;
    Key("image_flip_y");
    out_ << v.image_flip_y;
    Key("views");
    out_ << YAML::BeginMap;
    for (const ImageHalf half : kImageHalves) Pose(std::string(ToString(half)), v.sensor_from_view[static_cast<int>(half)]);
    out_ << YAML::EndMap;
    Key("refraction");
    out_ << YAML::BeginMap;
    Double("plane_height_mm", v.refraction.height_mm);
    Double("theta_rad", v.refraction.theta_rad);
    Double("phi_rad", v.refraction.phi_rad);
    Double("index_ratio", v.refraction.index_ratio);
    out_ << YAML::EndMap;
    Key("reference_pixels");
    out_ << YAML::BeginSeq;
    for (size_t i = 0; i < v.reference_pixels[0].size(); ++i) {
      out_ << YAML::Flow << YAML::BeginSeq;
      for (int half = 0; half < 2; ++half) {
        out_ << ExactDouble(v.reference_pixels[half][i].x()) << ExactDouble(v.reference_pixels[half][i].y());
      }
      out_ << YAML::EndSeq;
    }
    out_ << YAML::EndSeq;
    Key("dome_fit");
    out_ << YAML::BeginMap;
    Vector("center_mm", v.dome.center_mm);
    Double("radius_mm", v.dome.radius_mm);
    Double("rms_mm", v.dome.rms_mm);
    Double("max_mm", v.dome.max_mm);
    Double("pitch_mm", v.dome.pitch_mm);
    out_ << YAML::EndMap;
    Key("datasheet");
    out_ << YAML::BeginMap;
    Vector("position_noise_mm", v.datasheet.position_noise_mm);
    Vector("marker_force_noise_n", v.datasheet.marker_force_noise_n);
    Vector("resultant_force_noise_n", v.datasheet.resultant_force_noise_n);
    Vector("position_drift_mm_per_min", v.datasheet.position_drift_mm_per_min);
    Vector("marker_force_drift_n_per_min", v.datasheet.marker_force_drift_n_per_min);
    Vector("resultant_force_drift_n_per_min", v.datasheet.resultant_force_drift_n_per_min);
    Vector("resultant_relative_error_pct", v.datasheet.resultant_relative_error_pct);
    out_ << YAML::EndMap;
    out_ << YAML::EndMap;
  }

 private:
  YAML::Emitter out_;
};

constexpr double kMaxPositionNoiseMm = 1.0;

void RequireFiniteVector(const Eigen::Vector3d& v, const std::string& field, bool non_negative) {
  for (int i = 0; i < 3; ++i) {
    Require(std::isfinite(v(i)) && (!non_negative || v(i) >= 0), fmt::format("{}[{}]", field, i),
            non_negative ? "finite and >= 0" : "finite", v(i));
  }
}

void ValidateVendorCamera(const VendorCameraModelConfig& v, const CameraIntrinsics& camera,
                          int marker_count) {
  for (const ImageHalf half : kImageHalves) {
    const std::string field = fmt::format("camera_model.views.{}", ToString(half));
    const Rigid3& pose = v.sensor_from_view[static_cast<int>(half)];
    ValidateRotation(pose.linear(), field + ".rotation");
    RequirePosition(pose.translation(), field + ".position_mm");
    const std::vector<Eigen::Vector2d>& pixels = v.reference_pixels[static_cast<int>(half)];
    if (static_cast<int>(pixels.size()) != marker_count) {
      throw Error(fmt::format("sensor config: camera_model.reference_pixels: {} {} pixels, must be "
                              "one a marker (markers.rows * cols = {})",
                              pixels.size(), ToString(half), marker_count));
    }
    for (size_t i = 0; i < pixels.size(); ++i) {
      for (int k = 0; k < 2; ++k) {
        const int side = k == 0 ? camera.width : camera.height;
        Require(pixels[i](k) >= 0 && pixels[i](k) <= side - 1,
                fmt::format("camera_model.reference_pixels[{}] ({} view, {})", i, ToString(half),
                            k == 0 ? "u" : "v"),
                fmt::format("inside the {} x {} image", camera.width, camera.height), pixels[i](k));
      }
    }
  }
  const RefractionPlaneConfig& r = v.refraction;
  Require(std::abs(r.height_mm) <= SensorLimits::kMaxLengthMm, "camera_model.refraction.plane_height_mm",
          fmt::format("finite, |x| <= {} mm", SensorLimits::kMaxLengthMm), r.height_mm);
  Require(std::abs(r.theta_rad) < 0.5 * kPi, "camera_model.refraction.theta_rad",
          "in (-pi/2, pi/2)", r.theta_rad);
  Require(std::isfinite(r.phi_rad), "camera_model.refraction.phi_rad", "finite", r.phi_rad);
  Require(r.index_ratio >= 1.0 / SensorLimits::kMaxRefractiveIndex &&
              r.index_ratio <= SensorLimits::kMaxRefractiveIndex,
          "camera_model.refraction.index_ratio",
          fmt::format("in [1/{0}, {0}]", SensorLimits::kMaxRefractiveIndex), r.index_ratio);
  const DomeFitConfig& d = v.dome;
  RequirePosition(d.center_mm, "camera_model.dome_fit.center_mm");
  RequireLength(d.radius_mm, "camera_model.dome_fit.radius_mm");
  RequireLength(d.pitch_mm, "camera_model.dome_fit.pitch_mm");
  Require(d.rms_mm >= 0 && d.rms_mm <= d.max_mm, "camera_model.dome_fit.rms_mm", ">= 0 and <= max_mm",
          d.rms_mm);
  Require(d.max_mm <= SensorLimits::kMaxLengthMm, "camera_model.dome_fit.max_mm",
          fmt::format("<= {} mm", SensorLimits::kMaxLengthMm), d.max_mm);
  const VendorDatasheetConfig& s = v.datasheet;
  // The noise the force inverse's weight is chosen for (the discrepancy principle): 0 would
  // leave it unregularised, 1e308 regularise every force away. A Tac3D's is about 0.001 mm.
  for (int i = 0; i < 3; ++i) {
    Require(s.position_noise_mm(i) > 0 && s.position_noise_mm(i) <= kMaxPositionNoiseMm,
            fmt::format("camera_model.datasheet.position_noise_mm[{}]", i),
            fmt::format("in (0, {}] mm", kMaxPositionNoiseMm), s.position_noise_mm(i));
  }
  RequireFiniteVector(s.marker_force_noise_n, "camera_model.datasheet.marker_force_noise_n", true);
  RequireFiniteVector(s.resultant_force_noise_n, "camera_model.datasheet.resultant_force_noise_n", true);
  RequireFiniteVector(s.position_drift_mm_per_min, "camera_model.datasheet.position_drift_mm_per_min", false);
  RequireFiniteVector(s.marker_force_drift_n_per_min, "camera_model.datasheet.marker_force_drift_n_per_min",
                      false);
  RequireFiniteVector(s.resultant_force_drift_n_per_min,
                      "camera_model.datasheet.resultant_force_drift_n_per_min", false);
  RequireFiniteVector(s.resultant_relative_error_pct, "camera_model.datasheet.resultant_relative_error_pct",
                      true);
}

VendorCameraModelConfig ReadVendorCamera(YamlReader r) {
  VendorCameraModelConfig v;
  const std::string type = r.String("type");
  if (type != kVendorCameraModelType) {
    r.FailAt(r.Required("type"), r.Join("type"),
             fmt::format("'{}' is not a camera model tac3d knows (only {})", type, kVendorCameraModelType));
  }
  v.serial_number = r.String("serial_number");
  v.image_flip_x = r.Bool("image_flip_x");
  v.image_flip_y = r.Bool("image_flip_y");
  {
    YamlReader views = r.Child("views");
    for (const ImageHalf half : kImageHalves) {
      v.sensor_from_view[static_cast<int>(half)] = ReadPose(views.Child(std::string(ToString(half))));
    }
  }
  {
    YamlReader refraction = r.Child("refraction");
    v.refraction.height_mm = refraction.Double("plane_height_mm");
    v.refraction.theta_rad = refraction.Double("theta_rad");
    v.refraction.phi_rad = refraction.Double("phi_rad");
    v.refraction.index_ratio = refraction.Double("index_ratio");
  }
  {
    // One row a marker: [u_left, v_left, u_right, v_right].
    const YAML::Node rows = r.Sequence("reference_pixels");
    if (rows.size() > static_cast<size_t>(SensorLimits::kMaxMarkersPerSide * SensorLimits::kMaxMarkersPerSide)) {
      r.FailAt(rows, r.Join("reference_pixels"), fmt::format("{} rows: more than markers can be", rows.size()));
    }
    for (size_t i = 0; i < rows.size(); ++i) {
      const Eigen::Vector4d uv = r.VectorAt<4>(rows[i], fmt::format("{}[{}]", r.Join("reference_pixels"), i));
      v.reference_pixels[0].push_back(uv.head<2>());
      v.reference_pixels[1].push_back(uv.tail<2>());
    }
  }
  {
    YamlReader dome = r.Child("dome_fit");
    v.dome.center_mm = dome.Vector<3>("center_mm");
    v.dome.radius_mm = dome.Double("radius_mm");
    v.dome.rms_mm = dome.Double("rms_mm");
    v.dome.max_mm = dome.Double("max_mm");
    v.dome.pitch_mm = dome.Double("pitch_mm");
  }
  {
    YamlReader s = r.Child("datasheet");
    v.datasheet.position_noise_mm = s.Vector<3>("position_noise_mm");
    v.datasheet.marker_force_noise_n = s.Vector<3>("marker_force_noise_n");
    v.datasheet.resultant_force_noise_n = s.Vector<3>("resultant_force_noise_n");
    v.datasheet.position_drift_mm_per_min = s.Vector<3>("position_drift_mm_per_min");
    v.datasheet.marker_force_drift_n_per_min = s.Vector<3>("marker_force_drift_n_per_min");
    v.datasheet.resultant_force_drift_n_per_min = s.Vector<3>("resultant_force_drift_n_per_min");
    v.datasheet.resultant_relative_error_pct = s.Vector<3>("resultant_relative_error_pct");
  }
  return v;
}

ImageHalf ParseHalf(const std::string& s, const YamlReader& r, const std::string& key) {
  if (s == "left") return ImageHalf::kLeft;
  if (s == "right") return ImageHalf::kRight;
  r.Fail(r.Join(key), fmt::format("'{}' must be left or right", s));
}

LateralFace ParseLateralFace(const std::string& s, const YamlReader& r) {
  if (s == "free") return LateralFace::kFree;
  if (s == "fixed") return LateralFace::kFixed;
  r.Fail(r.Join("lateral_face"), fmt::format("'{}' must be free or fixed", s));
}

}  // namespace

void SensorConfig::Validate() const {
  const CameraIntrinsics& c = camera.intrinsics;
  ValidateIntrinsics(c, "camera");
  Require(camera.horizontal_fov_deg > 0 && camera.horizontal_fov_deg < 180,
          "camera.horizontal_fov_deg", "in (0, 180) deg", camera.horizontal_fov_deg);
  ValidateRotation(camera.sensor_from_cam.linear(), "camera.sensor_from_cam.rotation");
  RequirePosition(camera.sensor_from_cam.translation(), "camera.sensor_from_cam.position_mm");

  RequireLength(light_path.h_mm, "light_path.h_mm");
  RequireLength(light_path.l_mm, "light_path.l_mm");
  RequireLength(light_path.d_mm, "light_path.d_mm");
  Require(light_path.fov_deg > 0 && light_path.fov_deg < 180, "light_path.fov_deg",
          "in (0, 180) deg", light_path.fov_deg);

  if (!mirrors.empty() && mirrors.size() != 4) {
    throw Error(fmt::format("sensor config: mirrors: {} given, must be 4 (or none before design)",
                            mirrors.size()));
  }
  for (size_t i = 0; i < mirrors.size(); ++i) {
    ValidateRectangle(mirrors[i].surface, fmt::format("mirrors[{}]", i));
  }
  if (!virtual_cameras.empty() && virtual_cameras.size() != 2) {
    throw Error(fmt::format(
        "sensor config: virtual_cameras: {} given, must be 2 (or none before design)",
        virtual_cameras.size()));
  }
  for (size_t i = 0; i < virtual_cameras.size(); ++i) {
    const VirtualCameraConfig& v = virtual_cameras[i];
    const std::string field = fmt::format("virtual_cameras[{}]", i);
    ValidateIntrinsics(v.intrinsics, field + ".intrinsics");
    ValidateRotation(v.sensor_from_vcam.linear(), field + ".sensor_from_vcam.rotation");
    RequirePosition(v.sensor_from_vcam.translation(), field + ".sensor_from_vcam.position_mm");
    Require(v.column_begin >= 0 && v.column_begin < v.column_end, field + ".column_begin",
            ">= 0 and < column_end", v.column_begin);
    Require(v.column_end <= v.intrinsics.width, field + ".column_end", "<= the image width",
            v.column_end);
  }

  const ElasticBodyConfig& b = elastic_body;
  RequireLength(b.outer_radius_mm, "elastic_body.outer_radius_mm");
  RequireLength(b.thickness_mm, "elastic_body.thickness_mm");
  Require(b.base_diameter_mm > 0 && b.base_diameter_mm < 2 * b.outer_radius_mm,
          "elastic_body.base_diameter_mm", "> 0 and < 2 * outer_radius_mm", b.base_diameter_mm);
  Require(b.youngs_modulus_mpa > 0 && b.youngs_modulus_mpa <= SensorLimits::kMaxYoungsModulusMpa,
          "elastic_body.youngs_modulus_mpa",
          fmt::format("> 0 and <= {:g} MPa", SensorLimits::kMaxYoungsModulusMpa), b.youngs_modulus_mpa);
  Require(b.poisson_ratio > -1.0 && b.poisson_ratio < 0.5, "elastic_body.poisson_ratio",
          "in (-1, 0.5)", b.poisson_ratio);
  const std::string index_bound = fmt::format("in [1, {}]", SensorLimits::kMaxRefractiveIndex);
  Require(b.refractive_index >= 1.0 && b.refractive_index <= SensorLimits::kMaxRefractiveIndex,
          "elastic_body.refractive_index", index_bound, b.refractive_index);
  const double base_radius = 0.5 * b.base_diameter_mm;
  const double edge_thickness = SphereCenter().z() + std::sqrt(b.outer_radius_mm * b.outer_radius_mm -
                                                               base_radius * base_radius);
  Require(edge_thickness > 0, "elastic_body.base_diameter_mm",
          "small enough that the outer sphere stays above the base at its edge",
          b.base_diameter_mm);

  RequireLength(glass.thickness_mm, "glass.thickness_mm");
  Require(glass.refractive_index >= 1.0 && glass.refractive_index <= SensorLimits::kMaxRefractiveIndex,
          "glass.refractive_index", index_bound, glass.refractive_index);

  const MarkerConfig& m = markers;
  const std::string count_bound = fmt::format(">= 2 and <= {}", SensorLimits::kMaxMarkersPerSide);
  Require(m.rows >= 2 && m.rows <= SensorLimits::kMaxMarkersPerSide, "markers.rows", count_bound, m.rows);
  Require(m.cols >= 2 && m.cols <= SensorLimits::kMaxMarkersPerSide, "markers.cols", count_bound, m.cols);
  RequireLength(m.pitch_mm, "markers.pitch_mm");
  Require(m.dot_diameter_mm > 0 && m.dot_diameter_mm < m.pitch_mm, "markers.dot_diameter_mm",
          "> 0 and < pitch_mm", m.dot_diameter_mm);
  Require(m.depth_mm >= 0 && m.depth_mm < b.thickness_mm, "markers.depth_mm",
          ">= 0 and < elastic_body.thickness_mm", m.depth_mm);
  // The grid's corner dot must lie inside the base's footprint and under the surface.
  const double half_x = 0.5 * (m.cols - 1) * m.pitch_mm;
  const double half_y = 0.5 * (m.rows - 1) * m.pitch_mm;
  const double corner = std::hypot(half_x, half_y) + 0.5 * m.dot_diameter_mm;
  const double marker_radius = b.outer_radius_mm - m.depth_mm;
  if (!(corner < base_radius) || !(corner < marker_radius)) {
    throw Error(fmt::format(
        "sensor config: markers: the {}x{} grid at pitch {} mm reaches {:.3f} mm from the axis, "
        "beyond the fingertip (elastic_body.base_diameter_mm / 2 = {} mm)",
        m.rows, m.cols, m.pitch_mm, corner, base_radius));
  }
  const double corner_z =
      SphereCenter().z() + std::sqrt(marker_radius * marker_radius - corner * corner);
  Require(corner_z > 0, "markers.depth_mm",
          "small enough that the corner markers stay inside the elastic body", m.depth_mm);
  if (vendor_camera) ValidateVendorCamera(*vendor_camera, c, m.rows * m.cols);
}

Eigen::Vector3d RefractionPlaneConfig::Normal() const {
  return {std::sin(theta_rad) * std::cos(phi_rad), std::sin(theta_rad) * std::sin(phi_rad),
          std::cos(theta_rad)};
}

Eigen::Vector2d VendorCameraModelConfig::FlipPixel(const Eigen::Vector2d& pixel, int width, int height) const {
  return {image_flip_x ? width - 1 - pixel.x() : pixel.x(), image_flip_y ? height - 1 - pixel.y() : pixel.y()};
}

std::array<std::pair<int, int>, 2> VendorCameraModelConfig::ViewColumns(int width, int height) const {
  std::array<double, 2> lo, hi;  // each view's reference pixels' u range in the camera's image
  for (const ImageHalf half : kImageHalves) {
    const int h = static_cast<int>(half);
    lo[h] = std::numeric_limits<double>::infinity();
    hi[h] = -lo[h];
    for (const Eigen::Vector2d& p : reference_pixels[h]) {
      const double u = FlipPixel(p, width, height).x();
      lo[h] = std::min(lo[h], u);
      hi[h] = std::max(hi[h], u);
    }
  }
  const int first = lo[0] < lo[1] ? 0 : 1;  // the view on the image's left
  const int second = 1 - first;
  if (!(hi[first] < lo[second])) {
    throw Error(fmt::format("sensor config: camera_model.reference_pixels: the left view's span u = [{}, {}] and "
                            "the right view's [{}, {}] overlap in the camera's image: no column parts the two views",
                            lo[0], hi[0], lo[1], hi[1]));
  }
  const int cut = static_cast<int>(std::ceil(0.5 * (hi[first] + lo[second])));
  std::array<std::pair<int, int>, 2> columns;
  columns[first] = {0, cut};
  columns[second] = {cut, width};
  return columns;
}

Eigen::Vector3d SensorConfig::SphereCenter() const {
  return {0, 0, elastic_body.thickness_mm - elastic_body.outer_radius_mm};
}

std::vector<Eigen::Vector3d> SensorConfig::MarkerPositions() const {
  const double radius = elastic_body.outer_radius_mm - markers.depth_mm;
  const Eigen::Vector3d center = SphereCenter();
  std::vector<Eigen::Vector3d> positions;
  positions.reserve(markers.rows * markers.cols);
  for (int i = 0; i < markers.rows; ++i) {
    for (int j = 0; j < markers.cols; ++j) {
      const double x = (j - 0.5 * (markers.cols - 1)) * markers.pitch_mm;
      const double y = (i - 0.5 * (markers.rows - 1)) * markers.pitch_mm;
      positions.emplace_back(x, y, center.z() + std::sqrt(radius * radius - x * x - y * y));
    }
  }
  return positions;
}

OpticalLayout SensorConfig::MakeOpticalLayout(bool with_gel) const {
  if (mirrors.size() != 4) {
    throw Error("sensor config has no mirrors: run `tac3d design` first");
  }
  OpticalLayout layout;
  layout.intrinsics = camera.intrinsics;
  layout.sensor_from_cam = camera.sensor_from_cam;
  // Paper Fig. 2: the left half reflects on mirror 2 then 1, the right on 3 then 4.
  layout.mirrors[static_cast<int>(ImageHalf::kLeft)] = {mirrors[1].surface, mirrors[0].surface};
  layout.mirrors[static_cast<int>(ImageHalf::kRight)] = {mirrors[2].surface, mirrors[3].surface};
  layout.layers = MakeFlatLayers(with_gel);
  return layout;
}

FlatLayers SensorConfig::MakeFlatLayers(bool with_gel) const {
  return {with_gel, -glass.thickness_mm, glass.refractive_index, elastic_body.refractive_index};
}

SensorConfig ParseSensorConfig(const std::string& yaml_text, const std::string& source) {
  const YAML::Node root = ParseYamlDocument(yaml_text, source);
  if (!root || root.IsNull()) throw Error(fmt::format("{}: empty sensor config", source));
  SensorConfig c;
  {
    YamlReader r(root, "", &source);
    {
      YamlReader cam = r.Child("camera");
      c.camera.intrinsics = ReadIntrinsics(cam.Child("intrinsics"));
      c.camera.horizontal_fov_deg = cam.Double("horizontal_fov_deg");
      c.camera.sensor_from_cam = ReadPose(cam.Child("sensor_from_cam"));
    }
    {
      YamlReader lp = r.Child("light_path");
      c.light_path.h_mm = lp.Double("h_mm");
      c.light_path.l_mm = lp.Double("l_mm");
      c.light_path.d_mm = lp.Double("d_mm");
      c.light_path.fov_deg = lp.Double("fov_deg");
    }
    const YAML::Node mirrors = r.Required("mirrors");
    if (!mirrors.IsSequence()) r.Fail("mirrors", "must be a list");
    for (size_t i = 0; i < mirrors.size(); ++i) {
      YamlReader m(mirrors[i], fmt::format("mirrors[{}]", i), &source);
      MirrorConfig mirror;
      mirror.name = m.String("name");
      mirror.surface = ReadRectangle(m);
      c.mirrors.push_back(mirror);
    }
    const YAML::Node vcams = r.Required("virtual_cameras");
    if (!vcams.IsSequence()) r.Fail("virtual_cameras", "must be a list");
    for (size_t i = 0; i < vcams.size(); ++i) {
      YamlReader v(vcams[i], fmt::format("virtual_cameras[{}]", i), &source);
      VirtualCameraConfig vcam;
      vcam.name = v.String("name");
      vcam.half = ParseHalf(v.String("half"), v, "half");
      vcam.sensor_from_vcam = ReadPose(v.Child("sensor_from_vcam"));
      vcam.intrinsics = ReadIntrinsics(v.Child("intrinsics"));
      vcam.column_begin = v.Int("column_begin");
      vcam.column_end = v.Int("column_end");
      c.virtual_cameras.push_back(vcam);
    }
    {
      YamlReader m = r.Child("markers");
      c.markers.rows = m.Int("rows");
      c.markers.cols = m.Int("cols");
      c.markers.pitch_mm = m.Double("pitch_mm");
      c.markers.dot_diameter_mm = m.Double("dot_diameter_mm");
      c.markers.depth_mm = m.Double("depth_mm");
    }
    {
      YamlReader b = r.Child("elastic_body");
      c.elastic_body.outer_radius_mm = b.Double("outer_radius_mm");
      c.elastic_body.thickness_mm = b.Double("thickness_mm");
      c.elastic_body.base_diameter_mm = b.Double("base_diameter_mm");
      c.elastic_body.youngs_modulus_mpa = b.Double("youngs_modulus_mpa");
      c.elastic_body.poisson_ratio = b.Double("poisson_ratio");
      c.elastic_body.refractive_index = b.Double("refractive_index");
      c.elastic_body.lateral_face = ParseLateralFace(b.String("lateral_face"), b);
    }
    {
      YamlReader g = r.Child("glass");
      c.glass.thickness_mm = g.Double("thickness_mm");
      c.glass.refractive_index = g.Double("refractive_index");
    }
    if (r.Has("camera_model")) c.vendor_camera = ReadVendorCamera(r.Child("camera_model"));
  }
  try {
    c.Validate();
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", source, e.what()));
  }
  return c;
}

SensorConfig LoadSensorConfig(const std::string& path) {
  return ParseSensorConfig(ReadFileCapped(path, kMaxConfigFileBytes, "sensor config"), path);
}

std::string SensorConfigToYaml(const SensorConfig& c) {
  Writer w;
  YAML::Emitter& out = w.out();
  out << YAML::Comment("tac3d sensor config: mm, MPa, degrees; frames in docs/sensor-config.md");
  out << YAML::BeginMap;
  w.Key("camera");
  out << YAML::BeginMap;
  w.Intrinsics("intrinsics", c.camera.intrinsics);
  w.Double("horizontal_fov_deg", c.camera.horizontal_fov_deg);
  w.Pose("sensor_from_cam", c.camera.sensor_from_cam);
  out << YAML::EndMap;

  w.Key("light_path");
  out << YAML::BeginMap;
  w.Double("h_mm", c.light_path.h_mm);
  w.Double("l_mm", c.light_path.l_mm);
  w.Double("d_mm", c.light_path.d_mm);
  w.Double("fov_deg", c.light_path.fov_deg);
  out << YAML::EndMap;

  w.Key("mirrors");
  out << YAML::BeginSeq;
  for (const MirrorConfig& m : c.mirrors) {
    out << YAML::BeginMap;
    w.Key("name");
    out << m.name;
    w.Rectangle(m.surface);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  w.Key("virtual_cameras");
  out << YAML::BeginSeq;
  for (const VirtualCameraConfig& v : c.virtual_cameras) {
    out << YAML::BeginMap;
    w.Key("name");
    out << v.name;
    w.Key("half");
    out << std::string(ToString(v.half));
    w.Pose("sensor_from_vcam", v.sensor_from_vcam);
    w.Intrinsics("intrinsics", v.intrinsics);
    w.Key("column_begin");
    out << v.column_begin;
    w.Key("column_end");
    out << v.column_end;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  w.Key("markers");
  out << YAML::BeginMap;
  w.Key("rows");
  out << c.markers.rows;
  w.Key("cols");
  out << c.markers.cols;
  w.Double("pitch_mm", c.markers.pitch_mm);
  w.Double("dot_diameter_mm", c.markers.dot_diameter_mm);
  w.Double("depth_mm", c.markers.depth_mm);
  out << YAML::EndMap;

  w.Key("elastic_body");
  out << YAML::BeginMap;
  w.Double("outer_radius_mm", c.elastic_body.outer_radius_mm);
  w.Double("thickness_mm", c.elastic_body.thickness_mm);
  w.Double("base_diameter_mm", c.elastic_body.base_diameter_mm);
  w.Double("youngs_modulus_mpa", c.elastic_body.youngs_modulus_mpa);
  w.Double("poisson_ratio", c.elastic_body.poisson_ratio);
  w.Double("refractive_index", c.elastic_body.refractive_index);
  w.Key("lateral_face");
  out << (c.elastic_body.lateral_face == LateralFace::kFree ? "free" : "fixed");
  out << YAML::EndMap;

  w.Key("glass");
  out << YAML::BeginMap;
  w.Double("thickness_mm", c.glass.thickness_mm);
  w.Double("refractive_index", c.glass.refractive_index);
  out << YAML::EndMap;
  if (c.vendor_camera) w.VendorCamera(*c.vendor_camera);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void SaveSensorConfig(const SensorConfig& config, const std::string& path) {
  // Never write a file tac3d could not read back.
  try {
    config.Validate();
  } catch (const Error& e) {
    throw Error(fmt::format("not writing sensor config '{}': {}", path, e.what()));
  }
  WriteTextFileAtomically(path, SensorConfigToYaml(config));
}

}  // namespace tac3d
