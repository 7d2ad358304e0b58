#pragma once

#include <array>

#include <Eigen/Core>

namespace tac3d {

/// A pinhole camera with OpenCV's distortion model (k1, k2, p1, p2, k3). Pixel centres
/// are at integer coordinates, as in OpenCV.
struct CameraIntrinsics {
  int width = 640;
  int height = 480;
  double fx = 0.0;  ///< focal length, px
  double fy = 0.0;
  double cx = 0.0;  ///< principal point, px
  double cy = 0.0;
  std::array<double, 5> distortion{};  ///< k1, k2, p1, p2, k3 (OpenCV order)

  /// An ideal camera (no distortion, square pixels, centred principal point) whose image
  /// edges lie hfov/2 off the axis.
  static CameraIntrinsics FromFieldOfView(int width, int height, double horizontal_fov_deg);

  Eigen::Matrix3d K() const;

  /// Applies the distortion to normalised coordinates (x/z, y/z).
  Eigen::Vector2d Distort(const Eigen::Vector2d& normalized) const;
  /// Inverts Distort by Newton's method (to ~1e-14).
  Eigen::Vector2d Undistort(const Eigen::Vector2d& distorted) const;

  /// Pixel of a point in the camera frame. @pre p_in_cam.z() > 0.
  Eigen::Vector2d Project(const Eigen::Vector3d& p_in_cam) const;
  /// Unit direction, in the camera frame, of the ray through a pixel.
  Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel) const;

  bool operator==(const CameraIntrinsics&) const = default;
};

}  // namespace tac3d
