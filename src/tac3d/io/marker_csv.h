#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tac3d {

/// The most rows ReadMarkerPositionsCsv accepts: SensorLimits' 100 x 100 markers.
inline constexpr std::size_t kMaxMarkerCsvRows = 100 * 100;

/// Marker positions as CSV: a header line `x_mm,y_mm,z_mm`, then one line per marker in
/// grid order (row-major), sensor frame. Blank lines and lines starting with # are skipped.
/// @throws Error naming the file and line of anything malformed, or naming the file when it
///   does not exist, is a folder or not a regular file (a device, a pipe), or is larger than
///   kMaxConfigFileBytes (util/file_io.h).
std::vector<Eigen::Vector3d> ReadMarkerPositionsCsv(const std::string& path);
void WriteMarkerPositionsCsv(const std::vector<Eigen::Vector3d>& positions,
                             const std::string& path);

}  // namespace tac3d
