#pragma once

#include <vector>

#include <Eigen/Core>

namespace tac3d {

/// A flat rows x cols marker grid on an elastic half-space, for tests, benchmarks and a first
/// try without an FEM model. Marker (row, col) sits at x = (col - (cols-1)/2) pitch,
/// y = (row - (rows-1)/2) pitch, z = 0, index row * cols + col (as the FEM's markers).
struct SyntheticComplianceOptions {
  int rows = 20;
  int cols = 20;
  double pitch_mm = 1.27;
  double youngs_modulus_mpa = 1.0;
  double poisson_ratio = 0.48;

  /// @throws tac3d::Error naming the field: rows, cols in [1, 200]; pitch > 0; E > 0;
  ///   -1 < nu < 0.5.
  void Validate() const;
};

/// A compliance matrix H (3N x 3N, mm/N) in the paper's ordering (eq. 1) and its markers.
struct SyntheticCompliance {
  Eigen::MatrixXd h;
  /// Marker positions (mm), index row * cols + col.
  std::vector<Eigen::Vector3d> marker_positions;
};

/// The Boussinesq (normal) and Cerruti (tangential) surface displacements of a half-space
/// (Johnson, Contact Mechanics, eqs. 3.19, 3.86; z points out of the body) with the distance
/// rho between load and marker replaced by sqrt(rho^2 + c^2), c = pitch / (4 ln(1 + sqrt 2)):
/// then a marker's own normal compliance equals the centre deflection of a uniformly loaded
/// square patch of side pitch (Love 1929). Smooth, symmetric (reciprocity) and positive
/// definite, but not the sensor's dome: it stands in for H where only its shape matters.
/// @throws tac3d::Error if the options are invalid.
SyntheticCompliance CalcSyntheticCompliance(const SyntheticComplianceOptions& options);

}  // namespace tac3d
