#include "tac3d/stereo/refraction_compensation.h"

#include <cmath>
#include <random>

#include <Eigen/QR>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A point of the marker volume: over the undeformed marker sphere, shifted along z.
Eigen::Vector3d VolumePoint(const SensorConfig& config, double x, double y, double dz) {
  const double radius = config.elastic_body.outer_radius_mm - config.markers.depth_mm;
  const double z = config.SphereCenter().z() + std::sqrt(radius * radius - x * x - y * y);
  return {x, y, z + dz};
}

// The air-stereo observation of a true point, if both halves see it.
std::optional<Eigen::Vector3d> Observe(const StereoRig& rig, const Eigen::Vector3d& p) {
  const auto left = rig.Project(ImageHalf::kLeft, p);
  const auto right = rig.Project(ImageHalf::kRight, p);
  if (!left || !right) return std::nullopt;
  const Triangulation t = TriangulateMidpoint(rig, *left, *right);
  if (!t.valid) return std::nullopt;
  return t.point;
}

}  // namespace

void RefractionCompensationOptions::Validate() const {
  const OptionCheck require("refraction compensation");
  require(degree >= 1 && degree <= 6, "degree", "in [1, 6]", degree);
  require(samples_per_axis >= degree + 2 && samples_per_axis <= 60, "samples_per_axis",
          "in [degree + 2, 60]", samples_per_axis);
  require(margin_mm >= 0, "margin_mm", ">= 0", margin_mm);
  require(below_mm >= 0, "below_mm", ">= 0", below_mm);
  require(above_mm >= 0, "above_mm", ">= 0", above_mm);
  require(below_mm + above_mm > 0, "below_mm + above_mm", "> 0", below_mm + above_mm);
}

void RefractionCompensation::Monomials(const Eigen::Vector3d& observed, MonomialVector& m) const {
  const Eigen::Vector3d q = (observed - center_).cwiseQuotient(scale_);
  std::array<std::array<double, 7>, 3> powers;
  for (int a = 0; a < 3; ++a) {
    powers[a][0] = 1.0;
    for (int k = 1; k <= degree_; ++k) powers[a][k] = powers[a][k - 1] * q(a);
  }
  m.resize(static_cast<int>(exponents_.size()));
  for (size_t i = 0; i < exponents_.size(); ++i) {
    const Eigen::Vector3i& e = exponents_[i];
    m(static_cast<int>(i)) = powers[0][e(0)] * powers[1][e(1)] * powers[2][e(2)];
  }
}

RefractionCompensation RefractionCompensation::Fit(const StereoRig& rig, const SensorConfig& config,
                                                   const RefractionCompensationOptions& options) {
  options.Validate();
  RefractionCompensation c;
  c.degree_ = options.degree;
  for (int i = 0; i <= options.degree; ++i) {
    for (int j = 0; i + j <= options.degree; ++j) {
      for (int k = 0; i + j + k <= options.degree; ++k) c.exponents_.emplace_back(i, j, k);
    }
  }
  const double half_x = 0.5 * (config.markers.cols - 1) * config.markers.pitch_mm + options.margin_mm;
  const double half_y = 0.5 * (config.markers.rows - 1) * config.markers.pitch_mm + options.margin_mm;

  // Fitting pairs on a regular grid over the volume.
  std::vector<Eigen::Vector3d> observed, deviation;
  const int n = options.samples_per_axis;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < n; ++k) {
        const double x = -half_x + 2 * half_x * i / (n - 1);
        const double y = -half_y + 2 * half_y * j / (n - 1);
        const double dz = -options.below_mm + (options.below_mm + options.above_mm) * k / (n - 1);
        const Eigen::Vector3d truth = VolumePoint(config, x, y, dz);
        const auto seen = Observe(rig, truth);
        if (!seen) continue;
        observed.push_back(*seen);
        deviation.push_back(truth - *seen);
      }
    }
  }
  const int terms = static_cast<int>(c.exponents_.size());
  if (static_cast<int>(observed.size()) < 4 * terms) {
    throw Error(fmt::format("refraction compensation: only {} of {} sample points are seen by "
                            "both virtual cameras; check the calibration",
                            observed.size(), n * n * n));
  }
  Eigen::Vector3d lo = observed.front(), hi = observed.front();
  for (const auto& o : observed) {
    lo = lo.cwiseMin(o);
    hi = hi.cwiseMax(o);
  }
  c.center_ = 0.5 * (lo + hi);
  c.scale_ = (0.5 * (hi - lo)).cwiseMax(Eigen::Vector3d::Constant(1e-6));

  Eigen::MatrixXd a(observed.size(), terms);
  Eigen::MatrixXd b(observed.size(), 3);
  MonomialVector m;
  for (size_t s = 0; s < observed.size(); ++s) {
    c.Monomials(observed[s], m);
    a.row(static_cast<int>(s)) = m.transpose();
    b.row(static_cast<int>(s)) = deviation[s].transpose();
    c.summary_.max_deviation_mm = std::max(c.summary_.max_deviation_mm, deviation[s].norm());
  }
  c.coefficients_ = a.colPivHouseholderQr().solve(b).transpose();
  c.summary_.fit_samples = static_cast<int>(observed.size());
  c.summary_.terms = terms;

  // Validation on random points of the same volume, off the grid.
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> ux(-half_x, half_x), uy(-half_y, half_y),
      uz(-options.below_mm, options.above_mm);
  double sum2 = 0;
  int count = 0;
  for (int s = 0; s < 2000; ++s) {
    const Eigen::Vector3d truth = VolumePoint(config, ux(rng), uy(rng), uz(rng));
    const auto seen = Observe(rig, truth);
    if (!seen) continue;
    const double error = (c.Correct(*seen) - truth).norm();
    sum2 += error * error;
    c.summary_.validation_max_mm = std::max(c.summary_.validation_max_mm, error);
    ++count;
  }
  c.summary_.validation_rms_mm = count > 0 ? std::sqrt(sum2 / count) : 0.0;
  return c;
}

Eigen::Vector3d RefractionCompensation::Correct(const Eigen::Vector3d& observed) const {
  MonomialVector m;
  Monomials(observed, m);
  return observed + coefficients_ * m;
}

}  // namespace tac3d
