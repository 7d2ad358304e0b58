#include "tac3d/vendor_formats/vendor_calibration.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <string_view>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "tac3d/geometry/geometry.h"
#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

namespace tac3d {
namespace {

std::string PathIn(const std::string& folder, const char* file) {
  return (std::filesystem::path(folder) / file).string();
}

// The vendor's files hold many keys tac3d does not use: read only ours, each strictly.
YAML::Node LoadVendorYaml(const std::string& path) {
  return LoadYamlFile(path, "vendor calibration file");
}

// sensor.yaml: the serial number, the camera's resolution and flip (pipeline InputSource) and the
// marker grid (pipeline DMP3_by_Zhang).
void ReadSensorFile(const std::string& path, VendorCalibration* calibration) {
  const YAML::Node root = LoadVendorYaml(path);
  YamlReader r(root, "", &path);
  r.AllowUnknownKeys();
  calibration->serial_number = r.String("SN");
  calibration->camera_model.serial_number = calibration->serial_number;
  const YAML::Node pipeline = r.Sequence("pipeline");
  bool has_input = false, has_markers = false;
  for (size_t i = 0; i < pipeline.size(); ++i) {
    YamlReader stage = r.Element(pipeline, "pipeline", i);
    const std::string name = stage.String("name");
    if (name == "InputSource") {
      YamlReader config = stage.Child("config");
      calibration->intrinsics.width = config.Int("width");
      calibration->intrinsics.height = config.Int("height");
      calibration->camera_model.image_flip_x = config.Bool("flipX");
      calibration->camera_model.image_flip_y = config.Bool("flipY");
      has_input = true;
    } else if (name == "DMP3_by_Zhang") {
      YamlReader config = stage.Child("config");
      calibration->grid_cols = config.Int("nx");
      calibration->grid_rows = config.Int("ny");
      for (const int side : {calibration->grid_cols, calibration->grid_rows}) {
        if (side < 2 || side > SensorLimits::kMaxMarkersPerSide) {
          stage.FailAt(stage.Required("config"), stage.Join("config"),
                       fmt::format("a marker grid of {} x {}: each side must be 2 .. {}", calibration->grid_cols,
                                   calibration->grid_rows, SensorLimits::kMaxMarkersPerSide));
        }
      }
      has_markers = true;
    }
  }
  if (!has_input || !has_markers) {
    r.FailAt(pipeline, "pipeline", "must hold an InputSource stage and a DMP3_by_Zhang stage");
  }
}

Eigen::Matrix3d ReadRotation(YamlReader& view) {
  const YAML::Node node = view.Required("rotation");
  const Eigen::Matrix<double, 9, 1> flat = view.VectorAt<9>(node, view.Join("rotation"));
  const Eigen::Matrix3d r = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(flat.data());
  if (!(RotationDefect(r) < kRotationTolerance)) {
    view.FailAt(node, view.Join("rotation"),
                fmt::format("is not a rotation (max(|R R^T - I|, |det R - 1|) = {:.3g})", RotationDefect(r)));
  }
  return r;
}

// Reconstruction3D/parameters.yaml: intrinsics, distortion, the two views' poses, the refraction.
void ReadParametersFile(const std::string& path, VendorCalibration* calibration) {
  const YAML::Node root = LoadVendorYaml(path);
  YamlReader r(root, "", &path);
  r.AllowUnknownKeys();
  CameraIntrinsics& c = calibration->intrinsics;
  {
    YamlReader intrinsic = r.Child("intrinsic");
    c.fx = intrinsic.Double("fx");
    c.fy = intrinsic.Double("fy");
    c.cx = intrinsic.Double("cx");
    c.cy = intrinsic.Double("cy");
    if (intrinsic.Double("s") != 0.0) {
      intrinsic.FailAt(intrinsic.Required("s"), intrinsic.Join("s"),
                       "a skewed camera is not modelled (tac3d's cameras have square axes): must be 0");
    }
    if (!(c.fx > 0) || !(c.fy > 0)) intrinsic.FailAt(root["intrinsic"], "intrinsic", "fx and fy must be > 0");
    if (!(c.cx > 0 && c.cx < c.width) || !(c.cy > 0 && c.cy < c.height)) {
      intrinsic.FailAt(root["intrinsic"], "intrinsic",
                       fmt::format("the principal point ({}, {}) is outside the {} x {} image of sensor.yaml", c.cx,
                                   c.cy, c.width, c.height));
    }
  }
  {
    YamlReader distortion = r.Child("distortion");
    const char* keys[] = {"k1", "k2", "p1", "p2", "k3"};  // OpenCV's order
    for (int i = 0; i < 5; ++i) c.distortion[i] = distortion.Double(keys[i]);
  }
  {
    YamlReader extrinsic = r.Child("extrinsic");
    for (const ImageHalf half : kImageHalves) {
      YamlReader view = extrinsic.Child(std::string(ToString(half)));
      Rigid3 pose = Rigid3::Identity();
      pose.translation() = Eigen::Vector3d(view.Double("x"), view.Double("y"), view.Double("z"));
      pose.linear() = ReadRotation(view);
      calibration->camera_model.sensor_from_view[static_cast<int>(half)] = pose;
    }
  }
  {
    YamlReader refraction = r.Child("refraction");
    RefractionPlaneConfig& plane = calibration->camera_model.refraction;
    plane.index_ratio = refraction.Double("n21");
    plane.height_mm = refraction.Double("h0");
    plane.theta_rad = refraction.Double("theta");
    plane.phi_rad = refraction.Double("phi");
  }
}

// datasheet.yaml: the gel's E and nu and the vendor's accuracy figures.
void ReadDatasheetFile(const std::string& path, VendorCalibration* calibration) {
  const YAML::Node root = LoadVendorYaml(path);
  YamlReader r(root, "", &path);
  r.AllowUnknownKeys();
  {
    YamlReader parameters = r.Child("Parameters");
    calibration->youngs_modulus_mpa = parameters.Double("E");
    calibration->poisson_ratio = parameters.Double("P");
  }
  YamlReader accuracy = r.Child("Accuracy");
  VendorDatasheetConfig& d = calibration->camera_model.datasheet;
  d.position_noise_mm = accuracy.Vector<3>("Np");
  d.marker_force_noise_n = accuracy.Vector<3>("Nf");
  d.resultant_force_noise_n = accuracy.Vector<3>("Nfm");
  d.position_drift_mm_per_min = accuracy.Vector<3>("Dp");
  d.marker_force_drift_n_per_min = accuracy.Vector<3>("Df");
  d.resultant_force_drift_n_per_min = accuracy.Vector<3>("Dfm");
  d.resultant_relative_error_pct = accuracy.Vector<3>("Efm");
}

double ParsePixelCoordinate(std::string_view text, const std::string& path, int line) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) text.remove_suffix(1);
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
    throw Error(fmt::format("{}: line {}: '{}' is not a number", path, line, text));
  }
  return value;
}

// DMP3_by_Zhang/markers.txt: 2 * nx * ny lines "u,v", the left view's markers then the right's.
void ReadMarkersFile(const std::string& path, VendorCalibration* calibration) {
  const std::string text = ReadFileCapped(path, kMaxConfigFileBytes, "vendor markers file");
  const int markers = calibration->grid_rows * calibration->grid_cols;
  const CameraIntrinsics& c = calibration->intrinsics;
  auto& pixels = calibration->camera_model.reference_pixels;
  pixels = {};
  std::vector<Eigen::Vector2d> all;
  std::size_t begin = 0;
  int line = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string_view row(text.data() + begin, end - begin);
    begin = end + 1;
    ++line;
    const std::size_t comma = row.find(',');
    if (comma == std::string_view::npos) {
      throw Error(fmt::format("{}: line {}: '{}' is not a marker's pixel 'u,v'", path, line, row.substr(0, 60)));
    }
    const Eigen::Vector2d uv(ParsePixelCoordinate(row.substr(0, comma), path, line),
                             ParsePixelCoordinate(row.substr(comma + 1), path, line));
    if (!(uv.x() >= 0 && uv.x() <= c.width - 1 && uv.y() >= 0 && uv.y() <= c.height - 1)) {
      throw Error(fmt::format("{}: line {}: pixel ({}, {}) is outside the {} x {} image of {}", path, line, uv.x(),
                              uv.y(), c.width, c.height, kVendorSensorFile));
    }
    if (static_cast<int>(all.size()) == 2 * markers) {
      throw Error(fmt::format("{}: line {}: more than the 2 x {} marker lines the {} x {} grid of {} has", path,
                              line, markers, calibration->grid_cols, calibration->grid_rows, kVendorSensorFile));
    }
    all.push_back(uv);
  }
  if (static_cast<int>(all.size()) != 2 * markers) {
    throw Error(fmt::format("{}: {} marker lines, the {} x {} grid of {} needs {} (each marker's left-view pixel, "
                            "then each one's right-view pixel)",
                            path, all.size(), calibration->grid_cols, calibration->grid_rows, kVendorSensorFile,
                            2 * markers));
  }
  pixels[0].assign(all.begin(), all.begin() + markers);
  pixels[1].assign(all.begin() + markers, all.end());
}

}  // namespace

VendorCalibration ReadVendorCalibration(const std::string& folder) {
  VendorCalibration calibration;
  // sensor.yaml first: it gives the image size and grid the other files are checked against.
  ReadSensorFile(PathIn(folder, kVendorSensorFile), &calibration);
  ReadParametersFile(PathIn(folder, kVendorParametersFile), &calibration);
  ReadDatasheetFile(PathIn(folder, kVendorDatasheetFile), &calibration);
  ReadMarkersFile(PathIn(folder, kVendorMarkersFile), &calibration);
  return calibration;
}

SphereFit FitSphere(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 4) throw Error(fmt::format("a sphere needs 4 points or more, not {}", points.size()));
  // Algebraic fit: |p|^2 = 2 c.p + (r^2 - |c|^2), linear in c and the last term.
  const int n = static_cast<int>(points.size());
  Eigen::MatrixXd a(n, 4);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    a.row(i) << 2 * points[i].transpose(), 1.0;
    b(i) = points[i].squaredNorm();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 4) throw Error("the points lie on a plane (or a line): no sphere fits them");
  const Eigen::Vector4d x = qr.solve(b);
  SphereFit fit;
  fit.center = x.head<3>();
  fit.radius = std::sqrt(x(3) + fit.center.squaredNorm());
  // Gauss-Newton on the distances |p - c| - r, from the algebraic fit (which weights far points more).
  for (int iteration = 0; iteration < 20; ++iteration) {
    Eigen::MatrixXd j(n, 4);
    Eigen::VectorXd residual(n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d d = points[i] - fit.center;
      residual(i) = d.norm() - fit.radius;
      j.row(i) << -d.normalized().transpose(), -1.0;
    }
    const Eigen::Vector4d step = j.colPivHouseholderQr().solve(-residual);
    fit.center += step.head<3>();
    fit.radius += step(3);
    if (step.norm() < 1e-12) break;
  }
  double sum2 = 0.0;
  for (const Eigen::Vector3d& p : points) {
    const double e = std::abs((p - fit.center).norm() - fit.radius);
    sum2 += e * e;
    fit.max_error = std::max(fit.max_error, e);
  }
  fit.rms = std::sqrt(sum2 / n);
  return fit;
}

double MeanGridPitch(const std::vector<Eigen::Vector3d>& points, int rows, int cols) {
  TAC3D_DEMAND(static_cast<int>(points.size()) == rows * cols && rows >= 2 && cols >= 2);
  double sum = 0.0;
  int count = 0;
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const Eigen::Vector3d& p = points[i * cols + j];
      if (j + 1 < cols) sum += (points[i * cols + j + 1] - p).norm(), ++count;
      if (i + 1 < rows) sum += (points[(i + 1) * cols + j] - p).norm(), ++count;
    }
  }
  return sum / count;
}

namespace {

// A quarter of the pitch: three times HDL1-0001's worst ray gap and twice its worst distance off
// the dome, and far under a marker named for its neighbour (a pitch).
constexpr double kMaxMarkerDisagreementPitches = 0.25;

// The two views' reference pixels name the same markers: each marker's two rays meet (HDL1-0001:
// at most 0.08 mm apart) and the markers lie on the dome (at most 0.13 mm off its sphere). A
// folder whose right-view pixels belong to other markers triangulates them up to millimetres
// off it, and every position tac3d measured with it would be that far off.
void CheckMarkersAgree(const std::string& folder, const std::vector<Triangulation>& triangulated,
                       const DomeFitConfig& dome) {
  const double bound_mm = kMaxMarkerDisagreementPitches * dome.pitch_mm;
  const std::string markers_file = PathIn(folder, kVendorMarkersFile);
  for (size_t i = 0; i < triangulated.size(); ++i) {
    if (triangulated[i].residual > bound_mm) {
      throw Error(fmt::format("{}: marker {} (lines {} and {}): its two reference pixels' rays pass {:.3f} mm apart, "
                              "over {:.3f} mm ({} of the {:.3f} mm pitch): do both views' lines name the same markers?",
                              markers_file, i, i + 1, i + 1 + triangulated.size(), triangulated[i].residual, bound_mm,
                              kMaxMarkerDisagreementPitches, dome.pitch_mm));
    }
  }
  if (dome.max_mm > bound_mm) {
    throw Error(fmt::format("{}: the triangulated markers lie up to {:.3f} mm off the sphere fitted to them, over "
                            "{:.3f} mm ({} of the {:.3f} mm pitch): do both views' lines name the same markers?",
                            markers_file, dome.max_mm, bound_mm, kMaxMarkerDisagreementPitches, dome.pitch_mm));
  }
}

}  // namespace

SensorConfig ImportVendorSensor(const std::string& folder) {
  const VendorCalibration calibration = ReadVendorCalibration(folder);
  SensorConfig config;
  config.camera.intrinsics = calibration.intrinsics;
  config.camera.horizontal_fov_deg =
      RadToDeg(2.0 * std::atan(0.5 * calibration.intrinsics.width / calibration.intrinsics.fx));
  config.markers.rows = calibration.grid_rows;
  config.markers.cols = calibration.grid_cols;
  config.vendor_camera = calibration.camera_model;

  std::vector<Eigen::Vector3d> reference;
  const std::vector<Triangulation> triangulated = VendorStereo(config).TriangulateReference();
  for (size_t i = 0; i < triangulated.size(); ++i) {
    if (!triangulated[i].valid) {
      throw Error(fmt::format("{}: marker {} (lines {} and {}): its two reference pixels' rays do not meet in front "
                              "of the cameras",
                              PathIn(folder, kVendorMarkersFile), i, i + 1, i + 1 + triangulated.size()));
    }
    reference.push_back(triangulated[i].point);
  }
  const SphereFit sphere = FitSphere(reference);
  DomeFitConfig& dome = config.vendor_camera->dome;
  dome.center_mm = sphere.center;
  dome.radius_mm = sphere.radius;
  dome.rms_mm = sphere.rms;
  dome.max_mm = sphere.max_error;
  dome.pitch_mm = MeanGridPitch(reference, calibration.grid_rows, calibration.grid_cols);
  CheckMarkersAgree(folder, triangulated, dome);

  // The twin's axisymmetric dome from the fit: the markers' sphere is depth_mm under the outer
  // surface (the vendor states no depth: tac3d's default is kept), the base is the refracting
  // plane, as wide as the markers' sphere where it meets it.
  config.markers.pitch_mm = dome.pitch_mm;
  ElasticBodyConfig& body = config.elastic_body;
  body.outer_radius_mm = sphere.radius + config.markers.depth_mm;
  body.thickness_mm = sphere.center.z() + body.outer_radius_mm - calibration.camera_model.refraction.height_mm;
  const double base_height = calibration.camera_model.refraction.height_mm - sphere.center.z();
  body.base_diameter_mm = 2.0 * std::sqrt(std::max(0.0, sphere.radius * sphere.radius - base_height * base_height));
  body.youngs_modulus_mpa = calibration.youngs_modulus_mpa;
  body.poisson_ratio = calibration.poisson_ratio;
  body.refractive_index = calibration.camera_model.refraction.index_ratio;
  try {
    config.Validate();
  } catch (const Error& e) {
    throw Error(fmt::format("{}: the imported sensor is not valid: {}", folder, e.what()));
  }
  return config;
}

}  // namespace tac3d
