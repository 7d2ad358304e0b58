#pragma once

#include <array>
#include <optional>
#include <string_view>

#include <Eigen/Core>

#include "tac3d/geometry/geometry.h"
#include "tac3d/optics/camera.h"

namespace tac3d {

/// The camera's image is split at its principal point's column: the left half (u < cx)
/// looks through the left mirrors, the right half through the right ones.
enum class ImageHalf { kLeft = 0, kRight = 1 };
inline constexpr std::array<ImageHalf, 2> kImageHalves = {ImageHalf::kLeft, ImageHalf::kRight};
std::string_view ToString(ImageHalf half);

/// The two plane mirrors that fold one half of the view (paper Fig. 2): a camera ray meets
/// `inner` (mirror 2 or 3) first, then `outer` (mirror 1 or 4). Each mirror reflects on the
/// side its normal points to; its back is opaque.
struct MirrorPair {
  Rectangle3 inner;
  Rectangle3 outer;
};

/// The flat refracting layers under the fingertip: air below the glass, glass from
/// glass_bottom_z_mm to 0, silicone above 0 (sensor frame).
struct FlatLayers {
  bool has_gel = true;  ///< false: calibration set-up, the camera sees through air only
  double glass_bottom_z_mm = -2.0;
  double glass_index = 1.52;
  double silicone_index = 1.41;
};

/// Everything a camera ray meets: the camera, the four mirrors and the flat layers.
struct OpticalLayout {
  CameraIntrinsics intrinsics;
  Rigid3 sensor_from_cam = Rigid3::Identity();
  std::array<MirrorPair, 2> mirrors;  ///< indexed by ImageHalf
  FlatLayers layers;

  const MirrorPair& pair(ImageHalf half) const { return mirrors[static_cast<int>(half)]; }
  /// The virtual camera of a half: the real camera mirrored by the inner mirror, then by
  /// the outer one (two reflections make a proper rigid motion).
  Rigid3 SensorFromVirtualCamera(ImageHalf half) const;
};

enum class TraceStatus {
  kOk,
  kMissedMirrors,      ///< the ray meets no inner mirror from its reflective side
  kMissedOuterMirror,  ///< reflected by the inner mirror but misses the outer one
  kBlocked,            ///< after the outer mirror, an inner mirror is in the way
  kMissedGel,          ///< does not reach the glass going up (points away from the body)
  kTotalReflection,
};
std::string_view ToString(TraceStatus status);

/// A camera ray followed through the mirrors and, with a gel, refracted into the silicone.
struct TracedRay {
  TraceStatus status = TraceStatus::kMissedMirrors;
  ImageHalf half = ImageHalf::kLeft;
  Eigen::Vector3d inner_hit = Eigen::Vector3d::Zero();
  Eigen::Vector3d outer_hit = Eigen::Vector3d::Zero();
  Ray in_air;        ///< leaving the outer mirror (sensor frame)
  Ray in_silicone;   ///< from the glass/silicone interface (z = 0), when has_gel

  bool ok() const { return status == TraceStatus::kOk; }
};

/// Follows a ray leaving the real camera's centre (sensor frame).
TracedRay TraceCameraRay(const OpticalLayout& layout, const Ray& ray_in_sensor);
/// Follows the ray through a pixel (with distortion).
TracedRay TracePixel(const OpticalLayout& layout, const Eigen::Vector2d& pixel);

/// The exact image of a point seen by a (virtual) camera through the flat layers: the
/// refracted path from the point to the camera's centre (Snell's law solved to 1e-13),
/// then the camera model. Returns nothing if the point is not in front of the camera.
std::optional<Eigen::Vector2d> ProjectThroughLayers(const Rigid3& sensor_from_cam,
                                                    const CameraIntrinsics& intrinsics,
                                                    const FlatLayers& layers,
                                                    const Eigen::Vector3d& p_in_sensor);

/// ProjectThroughLayers for the virtual camera of one half. Does not check that the
/// mirrors are wide enough to see the point (TracePixel does).
std::optional<Eigen::Vector2d> ProjectPoint(const OpticalLayout& layout,
                                            ImageHalf half,
                                            const Eigen::Vector3d& p_in_sensor);

}  // namespace tac3d
