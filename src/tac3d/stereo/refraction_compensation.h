#pragma once

#include <vector>

#include <Eigen/Core>

#include "tac3d/stereo/stereo_rig.h"

namespace tac3d {

struct RefractionCompensationOptions {
  int degree = 3;              ///< total degree of the polynomial in x, y, z
  int samples_per_axis = 14;   ///< fitting grid over the marker volume (per axis)
  double margin_mm = 2.0;      ///< beyond the marker grid's extent in x and y
  double below_mm = 3.0;       ///< how far under the undeformed marker layer (pressed in)
  double above_mm = 0.5;       ///< how far over it

  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// The paper's refraction compensation (section IV.A): stereo through the glass and
/// silicone as if they were air sees a marker displaced; a polynomial of the observed
/// position gives that deviation. It is fitted numerically from the known geometry: points
/// over the marker volume are imaged exactly through the layers (ProjectThroughLayers) by
/// the calibrated rig, triangulated as in air, and the polynomial maps the observed point
/// back to the true one. No measured data is used.
class RefractionCompensation {
 public:
  struct Summary {
    int fit_samples = 0;
    int terms = 0;
    double max_deviation_mm = 0;      ///< largest refraction shift it corrects
    double validation_rms_mm = 0;     ///< on points off the fitting grid
    double validation_max_mm = 0;
  };

  /// @throws Error if the options are invalid or too few samples triangulate.
  static RefractionCompensation Fit(const StereoRig& rig, const SensorConfig& config,
                                    const RefractionCompensationOptions& options = {});

  /// The true position of a marker seen at `observed` by midpoint triangulation.
  Eigen::Vector3d Correct(const Eigen::Vector3d& observed) const;

  const Summary& summary() const { return summary_; }

 private:
  // At most 84 terms (degree 6): on the stack, so Correct never allocates.
  using MonomialVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 84, 1>;
  void Monomials(const Eigen::Vector3d& observed, MonomialVector& m) const;

  int degree_ = 3;
  std::vector<Eigen::Vector3i> exponents_;
  Eigen::Vector3d center_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d scale_ = Eigen::Vector3d::Ones();
  Eigen::Matrix<double, 3, Eigen::Dynamic> coefficients_;
  Summary summary_;
};

}  // namespace tac3d
