#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// The files of a vendor calibration folder, relative to it.
inline constexpr const char* kVendorParametersFile = "Reconstruction3D/parameters.yaml";
inline constexpr const char* kVendorMarkersFile = "DMP3_by_Zhang/markers.txt";
inline constexpr const char* kVendorSensorFile = "sensor.yaml";
inline constexpr const char* kVendorDatasheetFile = "datasheet.yaml";

/// What the vendor's folder states, as read (before any fit).
struct VendorCalibration {
  std::string serial_number;
  CameraIntrinsics intrinsics;  ///< resolution from sensor.yaml, the rest from parameters.yaml
  int grid_cols = 0;            ///< DMP3_by_Zhang nx
  int grid_rows = 0;            ///< DMP3_by_Zhang ny
  double youngs_modulus_mpa = 0.0;
  double poisson_ratio = 0.0;
  /// Every field but `dome` (filled by ImportVendorSensor) as the folder gives it.
  VendorCameraModelConfig camera_model;
};

/// Reads a Tac3D vendor calibration folder (the one holding Reconstruction3D/parameters.yaml,
/// DMP3_by_Zhang/markers.txt, sensor.yaml and datasheet.yaml; docs/real-sensors.md).
/// @throws Error naming the file and line of anything missing, malformed or inconsistent: a
///   missing file or key, a value that is not a number, a skew that is not 0, a rotation that
///   is not one, a markers.txt whose line count is not 2 * nx * ny, a pixel outside the image.
VendorCalibration ReadVendorCalibration(const std::string& folder);

/// A sphere fitted to points by least squares on their distances to it.
struct SphereFit {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 0.0;
  double rms = 0.0;        ///< RMS distance of the points off the sphere
  double max_error = 0.0;  ///< the largest one
};

/// Fits a sphere (algebraic fit, then Gauss-Newton on the geometric distances).
/// @throws Error for fewer than 4 points or points on a plane.
SphereFit FitSphere(const std::vector<Eigen::Vector3d>& points);

/// Mean distance between row and column neighbours of a row-major rows x cols grid of points.
double MeanGridPitch(const std::vector<Eigen::Vector3d>& points, int rows, int cols);

/// A tac3d sensor config for the sensor of a vendor calibration folder: the camera model as
/// read, the markers' reference positions triangulated with it (VendorStereo), a sphere fitted to
/// them (camera_model.dome_fit), and the twin's fields derived from that fit where the vendor
/// states nothing (docs/real-sensors.md lists which). Validated.
/// @throws Error as ReadVendorCalibration does, or if a reference pixel pair does not triangulate.
SensorConfig ImportVendorSensor(const std::string& folder);

}  // namespace tac3d
