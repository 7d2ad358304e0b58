#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/geometry/geometry.h"

namespace tac3d {

/// A dot calibration board as OpenCV's circle-grid finder sees it. Symmetric: dot (r, c)
/// at (c * spacing, r * spacing); asymmetric (OpenCV's layout): at
/// ((2c + r % 2) * spacing, r * spacing). Board frame: origin at dot (0, 0), the dots in
/// its z = 0 plane, x along a row, y down the columns, z away from the printed face.
/// Rows and columns of a board's dot grid at most: boards have tens, and a typo should not
/// allocate millions of dots.
inline constexpr int kMaxDotsPerSide = 1000;

struct CalibrationBoard {
  enum class Layout { kSymmetric, kAsymmetric };
  Layout layout = Layout::kSymmetric;
  int rows = 7;
  int cols = 7;
  double spacing_mm = 2.5;
  double dot_diameter_mm = 1.2;

  /// @throws Error naming the field and the bound.
  void Validate() const;
  /// Dot centres in the board frame, row-major (OpenCV's order for findCirclesGrid).
  std::vector<Eigen::Vector3d> DotCenters() const;
  /// The centre of the dot grid, board frame (z = 0).
  Eigen::Vector3d GridCenter() const;
  /// The shortest distance between two dots, mm (spacing, or sqrt(2) spacing when
  /// asymmetric).
  double NearestDotDistance() const;
  /// The reference placement (docs/calibration.md): the board lying flat on the glass
  /// face, printed side down, the grid's centre on the sensor's axis at z = 0, its rows
  /// along the sensor's x and its columns along y.
  Rigid3 ReferenceSensorFromBoard() const;

  bool operator==(const CalibrationBoard&) const = default;
};

/// The description of a calibration folder (board.yaml): the board, and which image is
/// the reference view with the board's pose in the sensor frame.
struct CalibrationBoardFile {
  CalibrationBoard board;
  std::string reference_image;  ///< file name inside the folder
  Rigid3 sensor_from_board = Rigid3::Identity();  ///< the board's pose in that image
};

/// Reads board.yaml. Every key is required; unknown keys are refused.
/// @throws Error naming the file, the key and what is wrong.
CalibrationBoardFile LoadCalibrationBoardFile(const std::string& path);
/// Writes board.yaml that LoadCalibrationBoardFile reads back exactly.
/// @throws Error if the file cannot be written.
void SaveCalibrationBoardFile(const CalibrationBoardFile& file, const std::string& path);

}  // namespace tac3d
