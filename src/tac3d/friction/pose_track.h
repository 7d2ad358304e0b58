#pragma once

#include <string>
#include <vector>

#include "tac3d/geometry/geometry.h"

namespace tac3d::friction {

/// One timestamped pose of the sensor in the world (a motion-capture sample).
struct TimedPose {
  double t_s = 0.0;
  Rigid3 world_from_sensor = Rigid3::Identity();
  int line = 0;  ///< line of the source file it came from (0: not from a file)
};

/// world_from_sensor over time from timestamped samples, interpolated to any time inside
/// their span: linear in position, slerp in rotation (tac3d::InterpolatePose, shared with the
/// twin's Trajectory).
class PoseTrack {
 public:
  /// How far a quaternion's norm may be from 1 before a file is rejected: motion-capture
  /// exports print about 6 decimals, so a unit quaternion's norm is 1 within ~1e-6; 1e-3 lets
  /// rounded files through and rejects a wrong column order or units.
  static constexpr double kDefaultUnitTolerance = 1e-3;

  /// @param source the file (or other origin) named in error messages.
  /// @throws Error if there are no poses or times do not strictly increase.
  PoseTrack(std::vector<TimedPose> poses, std::string source);

  /// Reads a CSV with the header `t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz` (blank lines and lines
  /// starting with '#' are skipped; spaces are ignored), one pose a line: time in s, the
  /// sensor origin in the world in mm, the rotation world_from_sensor as a quaternion.
  /// Quaternions are normalised after the check.
  /// @param unit_tolerance the largest accepted | |q| - 1 |.
  /// @throws Error naming the file and line: a missing or wrong header, not 8 finite numbers,
  ///   a quaternion whose norm is off 1 by more than unit_tolerance, a time that goes back
  ///   (or repeats); naming the file when it does not exist, is a folder or not a regular file
  ///   (a device, a pipe), is larger than 256 MiB, cannot be read or holds no pose.
  static PoseTrack ReadCsv(const std::string& path, double unit_tolerance = kDefaultUnitTolerance);

  /// The pose at time t_s (s).
  /// @throws Error naming the source, its first and last lines and times, if t_s is outside
  ///   [first t_s, last t_s] (poses must cover every frame's time; no extrapolation).
  Rigid3 At(double t_s) const;

  const std::vector<TimedPose>& poses() const { return poses_; }
  const std::string& source() const { return source_; }
  double begin_s() const { return poses_.front().t_s; }
  double end_s() const { return poses_.back().t_s; }

 private:
  std::vector<TimedPose> poses_;
  std::string source_;
};

}  // namespace tac3d::friction
