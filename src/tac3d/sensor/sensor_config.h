#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/geometry/geometry.h"
#include "tac3d/imagefile/image_decode.h"
#include "tac3d/optics/camera.h"
#include "tac3d/optics/optical_layout.h"

namespace tac3d {

/// Upper bounds SensorConfig::Validate enforces beyond the physical ones, far above any
/// fingertip sensor, so a typo (a width of 2e9, 10000 x 10000 markers) is an error instead
/// of an allocation that never ends (docs/sensor-config.md lists them).
struct SensorLimits {
  static constexpr int kMaxImageSidePx = tac3d::kMaxImageSidePx;  ///< camera width and height
  static constexpr int kMaxMarkersPerSide = 100;      ///< markers.rows and cols
  static constexpr double kMaxLengthMm = 1000.0;      ///< every length and |coordinate|
  static constexpr double kMaxFocalLengthPx = 1e6;    ///< fx, fy
  static constexpr double kMaxYoungsModulusMpa = 1e3; ///< silicones are 0.05-10 MPa
  static constexpr double kMaxRefractiveIndex = 3.0;
};

/// How far from a rotation (RotationDefect) a rotation in a sensor's files may be.
inline constexpr double kRotationTolerance = 1e-6;

/// The real camera (paper: IMX219-77, 48 deg horizontal field of view).
struct CameraConfig {
  CameraIntrinsics intrinsics = CameraIntrinsics::FromFieldOfView(640, 480, 48.0);
  double horizontal_fov_deg = 48.0;
  /// Camera frame: x to the image's right, y down, z along the optical axis.
  Rigid3 sensor_from_cam = Rigid3(Eigen::Translation3d(0, 0, -40));
};

/// The light-path design parameters (paper Fig. 4).
struct LightPathConfig {
  double h_mm = 40.0;      ///< camera to the elastic body's face
  double l_mm = 40.0;      ///< length of the fingertip seen by each virtual camera
  double d_mm = 8.0;       ///< thickness of the elastic body
  double fov_deg = 48.0;   ///< the camera's horizontal field of view (phi)
};

/// A plane mirror: reflects on the side its normal (u_axis x v_axis) points to.
struct MirrorConfig {
  std::string name;
  Rectangle3 surface;
};

/// A virtual camera: the real one seen through the two mirrors of one image half.
struct VirtualCameraConfig {
  std::string name;  ///< "vcam_left" or "vcam_right"
  ImageHalf half = ImageHalf::kLeft;
  Rigid3 sensor_from_vcam = Rigid3::Identity();
  CameraIntrinsics intrinsics;
  /// The columns of the full image this camera owns: [column_begin, column_end).
  int column_begin = 0;
  int column_end = 0;
};

/// The marker layer: a rows x cols grid of dark dots under the outer surface.
struct MarkerConfig {
  int rows = 20;
  int cols = 20;
  double pitch_mm = 1.27;
  double dot_diameter_mm = 0.6;
  double depth_mm = 0.5;  ///< under the outer surface, along its normal
};

enum class LateralFace { kFree, kFixed };

/// The silicone dome: base a disc on the glass at z = 0, outer surface a sphere.
struct ElasticBodyConfig {
  double outer_radius_mm = 45.0;
  double thickness_mm = 8.0;       ///< on the axis
  double base_diameter_mm = 40.0;
  double youngs_modulus_mpa = 1.0;
  double poisson_ratio = 0.48;
  double refractive_index = 1.41;
  LateralFace lateral_face = LateralFace::kFree;
};

/// The glass plate under the elastic body, from z = -thickness to 0.
struct GlassConfig {
  double thickness_mm = 2.0;
  double refractive_index = 1.52;
};

/// The refracting plane of the vendor's camera model: the plane through (0, 0, height_mm) whose
/// normal is (sin theta cos phi, sin theta sin phi, cos theta), from air (camera side) into the
/// gel with index ratio n21 = n_gel / n_air.
struct RefractionPlaneConfig {
  double height_mm = 0.0;  ///< h0
  double theta_rad = 0.0;
  double phi_rad = 0.0;
  double index_ratio = 1.0;  ///< n21

  Eigen::Vector3d Normal() const;
};

/// A sphere fitted to the markers' reference positions (least squares on the distances).
struct DomeFitConfig {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 0.0;
  double rms_mm = 0.0;    ///< RMS of the markers' distances off the sphere
  double max_mm = 0.0;    ///< the largest distance off it
  double pitch_mm = 0.0;  ///< mean distance between grid neighbours
};

/// The vendor's datasheet figures for one sensor (standard deviations and drifts per axis x, y, z).
struct VendorDatasheetConfig {
  Eigen::Vector3d position_noise_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d marker_force_noise_n = Eigen::Vector3d::Zero();
  Eigen::Vector3d resultant_force_noise_n = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_drift_mm_per_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d marker_force_drift_n_per_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d resultant_force_drift_n_per_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d resultant_relative_error_pct = Eigen::Vector3d::Zero();
};

/// A real Tac3D's camera model as its vendor calibrates it (docs/real-sensors.md): one physical
/// camera (SensorConfig::camera.intrinsics, with OpenCV distortion) seen as two pinhole virtual
/// cameras, whose rays refract once at a plane. Imported by `tac3d import-vendor`; the twin's
/// mirror model (mirrors, virtual_cameras) stays empty for such a sensor.
struct VendorCameraModelConfig {
  std::string serial_number;
  bool image_flip_x = false;  ///< the vendor mirrors the camera's image before it is processed
  bool image_flip_y = false;
  /// Each view's camera-to-sensor pose (centre in mm, rotation), indexed by ImageHalf.
  std::array<Rigid3, 2> sensor_from_view = {Rigid3::Identity(), Rigid3::Identity()};
  RefractionPlaneConfig refraction;
  /// Each marker's pixel in both views of the undeformed gel, row-major marker order
  /// (rows * cols entries each), indexed by ImageHalf.
  std::array<std::vector<Eigen::Vector2d>, 2> reference_pixels;
  DomeFitConfig dome;
  VendorDatasheetConfig datasheet;
};

/// One description of a sensor: everything the software needs to know about it. The
/// defaults are the paper's prototype (DESIGN.md); `mirrors` and `virtual_cameras` are
/// empty until `tac3d design` (or calibration) fills them.
struct SensorConfig {
  CameraConfig camera;
  LightPathConfig light_path;
  std::vector<MirrorConfig> mirrors;  ///< mirror_1 .. mirror_4 (paper Fig. 2)
  std::vector<VirtualCameraConfig> virtual_cameras;
  MarkerConfig markers;
  ElasticBodyConfig elastic_body;
  GlassConfig glass;
  /// Set for a real sensor imported from its vendor's calibration (YAML key `camera_model`).
  std::optional<VendorCameraModelConfig> vendor_camera;

  /// Checks every value against its physical bound.
  /// @throws Error naming the field and the bound.
  void Validate() const;

  /// The outer-surface sphere's centre (on the axis, below the base).
  Eigen::Vector3d SphereCenter() const;
  /// Undeformed marker centres, row-major (index = row * cols + col), sensor frame:
  /// a regular grid in x, y projected onto the sphere `depth_mm` under the outer surface.
  std::vector<Eigen::Vector3d> MarkerPositions() const;
  /// The mirrors and refracting layers as the ray tracer wants them.
  /// @throws Error if the mirrors have not been designed.
  OpticalLayout MakeOpticalLayout(bool with_gel = true) const;
  /// The glass and silicone under the markers (with_gel false: air only, as calibrated).
  FlatLayers MakeFlatLayers(bool with_gel = true) const;
};

/// Reads a sensor description. Every key is required; unknown keys are refused.
/// @throws Error naming the file, the key and what is wrong.
SensorConfig LoadSensorConfig(const std::string& path);
/// Parses YAML text (`source` names it in error messages).
SensorConfig ParseSensorConfig(const std::string& yaml_text, const std::string& source = "<text>");
/// Writes YAML that LoadSensorConfig reads back bit for bit.
std::string SensorConfigToYaml(const SensorConfig& config);
void SaveSensorConfig(const SensorConfig& config, const std::string& path);

}  // namespace tac3d
