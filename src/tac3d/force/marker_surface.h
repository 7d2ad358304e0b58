#pragma once

#include <vector>

#include <Eigen/Core>

namespace tac3d {

struct ContactOptions {
  /// A marker is in contact when its normal force (pressing into the body) exceeds this (N).
  double contact_threshold_n = 0.02;

  /// @throws tac3d::Error naming the field: contact_threshold_n >= 0 and finite.
  void Validate() const;
};

/// Each marker's force split along the deformed surface's normal (paper section IV.B).
struct ForceDecomposition {
  /// Outward unit normal of the deformed marker surface at each marker (one column a marker).
  Eigen::Matrix3Xd normals;
  /// -(f . n) (N): positive when the force presses into the body.
  Eigen::VectorXd normal_force_n;
  /// f - (f . n) n (N), one column a marker.
  Eigen::Matrix3Xd tangential_force_n;
  /// normal_force_n > ContactOptions::contact_threshold_n.
  std::vector<bool> contact;
  int num_contact = 0;
  /// Markers whose normal could not be formed from valid neighbours and is the rest
  /// surface's normal instead.
  int num_rest_normals = 0;
};

/// The rows x cols grid of markers (index row * cols + col, rows along y, cols along x) as a
/// surface: normals of its deformed shape from the tangents along the row and the column, each
/// the central difference of the two neighbours' positions, or a one-sided difference at the
/// border and next to invalid markers; n = t_col x t_row normalised and oriented like the rest
/// surface's normal (outwards: +z on the dome). Second-order accurate inside, first-order at
/// the border.
class MarkerSurface {
 public:
  /// @param rest_positions_mm the rows * cols rest positions (mm), index row * cols + col.
  /// @throws tac3d::Error if rows or cols < 2, the positions are not rows * cols, the options
  ///   are invalid, or the rest grid is degenerate (a zero-area cell at some marker).
  MarkerSurface(int rows,
                int cols,
                std::vector<Eigen::Vector3d> rest_positions_mm,
                const ContactOptions& options = {});

  /// Unit normals of the surface rest + d (one column a marker). A marker whose row or column
  /// has no valid pair of markers within two steps to form a tangent gets its rest normal.
  /// @param d_mm displacements (3N, paper ordering); non-finite entries mark a marker invalid.
  /// @param valid one flag a marker, or empty for all valid.
  /// @param num_rest_normals if not null, set to the markers given their rest normal.
  /// @throws tac3d::Error if d_mm or valid has the wrong size.
  Eigen::Matrix3Xd CalcNormals(const Eigen::VectorXd& d_mm,
                               const std::vector<bool>& valid,
                               int* num_rest_normals = nullptr) const;

  /// Normals, normal and tangential forces and the contact mask.
  /// @param forces_n marker forces (3N, paper ordering), e.g. ForceFrame::forces_n.
  /// @throws tac3d::Error if a size is wrong.
  ForceDecomposition Decompose(const Eigen::VectorXd& d_mm,
                               const std::vector<bool>& valid,
                               const Eigen::VectorXd& forces_n) const;

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  const Eigen::Matrix3Xd& rest_normals() const { return rest_normals_; }

 private:
  // Normals of `positions` where `valid`; false where a tangent is missing or degenerate.
  std::vector<bool> CalcRawNormals(const Eigen::Matrix3Xd& positions,
                                   const std::vector<bool>& valid,
                                   Eigen::Matrix3Xd* normals) const;

  int rows_;
  int cols_;
  Eigen::Matrix3Xd rest_positions_;
  Eigen::Matrix3Xd rest_normals_;
  ContactOptions options_;
};

}  // namespace tac3d
