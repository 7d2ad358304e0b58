#include "tac3d/force/marker_surface.h"

#include <array>
#include <cmath>

#include <Eigen/Geometry>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A cross product shorter than this fraction of |t_col| |t_row| has no usable direction.
constexpr double kMinSine = 1e-6;

}  // namespace

void ContactOptions::Validate() const {
  if (!(contact_threshold_n >= 0.0 && std::isfinite(contact_threshold_n))) {
    throw Error(fmt::format("ContactOptions.contact_threshold_n must be >= 0 and finite, got {}",
                            contact_threshold_n));
  }
}

MarkerSurface::MarkerSurface(int rows,
                             int cols,
                             std::vector<Eigen::Vector3d> rest_positions_mm,
                             const ContactOptions& options)
    : rows_(rows), cols_(cols), options_(options) {
  options_.Validate();
  if (rows < 2 || cols < 2) {
    throw Error(fmt::format("MarkerSurface: the grid needs rows, cols >= 2, got {} x {}", rows, cols));
  }
  if (static_cast<int>(rest_positions_mm.size()) != rows * cols) {
    throw Error(fmt::format("MarkerSurface: {} rest positions for a {} x {} grid",
                            rest_positions_mm.size(), rows, cols));
  }
  rest_positions_.resize(3, rows * cols);
  for (int i = 0; i < rows * cols; ++i) rest_positions_.col(i) = rest_positions_mm[i];
  const std::vector<bool> ok =
      CalcRawNormals(rest_positions_, std::vector<bool>(rows * cols, true), &rest_normals_);
  for (int i = 0; i < rows * cols; ++i) {
    if (!ok[i]) throw Error(fmt::format("MarkerSurface: the rest grid is degenerate at marker {}", i));
  }
  // Outwards is the side the grid's mean normal points to along +z (the dome's axis).
  if (rest_normals_.row(2).sum() < 0.0) rest_normals_ = -rest_normals_;
}

std::vector<bool> MarkerSurface::CalcRawNormals(const Eigen::Matrix3Xd& positions,
                                                const std::vector<bool>& valid,
                                                Eigen::Matrix3Xd* normals) const {
  const int n = rows_ * cols_;
  normals->resize(3, n);
  std::vector<bool> ok(n, false);
  const auto index = [&](int row, int col) { return row * cols_ + col; };
  // The difference of two valid markers along one grid direction through (row, col), in order
  // of preference: the central pair, one side and the marker, then two markers on one side
  // (so a lost marker still gets the surface's normal from its neighbours).
  const auto tangent = [&](int row, int col, int d_row, int d_col, Eigen::Vector3d* t) {
    static constexpr std::array<std::array<int, 2>, 5> kPairs = {
        {{-1, 1}, {0, 1}, {-1, 0}, {1, 2}, {-2, -1}}};
    for (const auto& [a, b] : kPairs) {
      const int r0 = row + a * d_row, c0 = col + a * d_col;
      const int r1 = row + b * d_row, c1 = col + b * d_col;
      if (r0 < 0 || c0 < 0 || r1 >= rows_ || c1 >= cols_) continue;
      if (!valid[index(r0, c0)] || !valid[index(r1, c1)]) continue;
      *t = positions.col(index(r1, c1)) - positions.col(index(r0, c0));
      return true;
    }
    return false;
  };
  for (int row = 0; row < rows_; ++row) {
    for (int col = 0; col < cols_; ++col) {
      Eigen::Vector3d t_col, t_row;
      if (!tangent(row, col, 0, 1, &t_col) || !tangent(row, col, 1, 0, &t_row)) continue;
      const Eigen::Vector3d normal = t_col.cross(t_row);
      if (!(normal.norm() > kMinSine * t_col.norm() * t_row.norm())) continue;
      normals->col(index(row, col)) = normal.normalized();
      ok[index(row, col)] = true;
    }
  }
  return ok;
}

Eigen::Matrix3Xd MarkerSurface::CalcNormals(const Eigen::VectorXd& d_mm,
                                            const std::vector<bool>& valid,
                                            int* num_rest_normals) const {
  const int n = rows_ * cols_;
  if (d_mm.size() != 3 * n) {
    throw Error(fmt::format("MarkerSurface: D has {} entries, expected 3N = {}", d_mm.size(), 3 * n));
  }
  if (!valid.empty() && static_cast<int>(valid.size()) != n) {
    throw Error(fmt::format("MarkerSurface: {} validity flags for {} markers", valid.size(), n));
  }
  Eigen::Matrix3Xd positions = rest_positions_;
  std::vector<bool> usable(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d d(d_mm(i), d_mm(n + i), d_mm(2 * n + i));
    usable[i] = (valid.empty() || valid[i]) && d.allFinite();
    if (usable[i]) positions.col(i) += d;
  }
  Eigen::Matrix3Xd normals;
  const std::vector<bool> ok = CalcRawNormals(positions, usable, &normals);
  int rest_count = 0;
  for (int i = 0; i < n; ++i) {
    if (!ok[i]) {
      normals.col(i) = rest_normals_.col(i);
      ++rest_count;
    } else if (normals.col(i).dot(rest_normals_.col(i)) < 0.0) {
      normals.col(i) = -normals.col(i);
    }
  }
  if (num_rest_normals != nullptr) *num_rest_normals = rest_count;
  return normals;
}

ForceDecomposition MarkerSurface::Decompose(const Eigen::VectorXd& d_mm,
                                            const std::vector<bool>& valid,
                                            const Eigen::VectorXd& forces_n) const {
  const int n = rows_ * cols_;
  if (forces_n.size() != 3 * n) {
    throw Error(fmt::format("MarkerSurface: F has {} entries, expected 3N = {}", forces_n.size(),
                            3 * n));
  }
  ForceDecomposition result;
  result.normals = CalcNormals(d_mm, valid, &result.num_rest_normals);
  result.normal_force_n.resize(n);
  result.tangential_force_n.resize(3, n);
  result.contact.resize(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d f(forces_n(i), forces_n(n + i), forces_n(2 * n + i));
    const Eigen::Vector3d normal = result.normals.col(i);
    const double f_dot_n = f.dot(normal);
    result.normal_force_n(i) = -f_dot_n;
    result.tangential_force_n.col(i) = f - f_dot_n * normal;
    result.contact[i] = result.normal_force_n(i) > options_.contact_threshold_n;
    result.num_contact += result.contact[i] ? 1 : 0;
  }
  return result;
}

}  // namespace tac3d
