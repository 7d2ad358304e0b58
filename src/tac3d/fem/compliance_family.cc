#include "tac3d/fem/compliance_family.h"

#include <fmt/ranges.h>

#include <algorithm>

#include "tac3d/fem/compliance.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {

double ShearToBulkRatio(double poisson_ratio) {
  return 3.0 * (1.0 - 2.0 * poisson_ratio) / (2.0 * (1.0 + poisson_ratio));
}

ComplianceFamily::ComplianceFamily(const BodyModelOptions& options,
                                   std::vector<double> poisson_nodes,
                                   const std::string& cache_dir,
                                   bool show_progress)
    : options_(options), poisson_nodes_(std::move(poisson_nodes)) {
  std::sort(poisson_nodes_.begin(), poisson_nodes_.end());
  if (poisson_nodes_.size() < 2 ||
      std::adjacent_find(poisson_nodes_.begin(), poisson_nodes_.end()) != poisson_nodes_.end()) {
    throw Error(
        fmt::format("ComplianceFamily needs at least 2 distinct Poisson's ratio nodes, got {}",
                    fmt::join(poisson_nodes_, ", ")));
  }
  // Every node checked before the first (expensive) build.
  std::vector<BodyModelOptions> nodes;
  for (double nu : poisson_nodes_) {
    nodes.push_back(options);
    nodes.back().material.poisson_ratio = nu;
    nodes.back().Validate();
  }
  for (const BodyModelOptions& node : nodes) {
    ComplianceModel model = cache_dir.empty()
                                ? CalcComplianceModel(node, show_progress)
                                : LoadOrBuildComplianceModel(node, cache_dir, show_progress).model;
    shear_scaled_h_.push_back(node.material.shear_modulus() * model.h);
    if (marker_positions_.empty()) marker_positions_ = std::move(model.marker_positions);
  }
  options_.material.poisson_ratio = poisson_nodes_.front();
}

Eigen::MatrixXd ComplianceFamily::CalcH(const ElasticMaterial& material) const {
  material.Validate();
  const double nu = material.poisson_ratio;
  if (nu < min_poisson_ratio() || nu > max_poisson_ratio()) {
    throw Error(fmt::format("Poisson's ratio {} is outside the compliance family's nodes [{}, {}]",
                            nu,
                            min_poisson_ratio(),
                            max_poisson_ratio()));
  }
  const double s = ShearToBulkRatio(nu);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(shear_scaled_h_[0].rows(), shear_scaled_h_[0].cols());
  for (size_t i = 0; i < poisson_nodes_.size(); ++i) {
    double weight = 1.0;
    for (size_t j = 0; j < poisson_nodes_.size(); ++j) {
      if (j == i) continue;
      const double sj = ShearToBulkRatio(poisson_nodes_[j]);
      weight *= (s - sj) / (ShearToBulkRatio(poisson_nodes_[i]) - sj);
    }
    if (weight != 0.0) h += weight * shear_scaled_h_[i];
  }
  return h / material.shear_modulus();
}

}  // namespace tac3d::fem
