#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "tac3d/fem/body_model.h"
#include "tac3d/material/elastic_material.h"

namespace tac3d::fem {

/// The ratio G / K of the shear to the bulk modulus, 3 (1 - 2 nu) / (2 (1 + nu)): the one
/// material parameter the shape of H depends on (0 for an incompressible solid).
double ShearToBulkRatio(double poisson_ratio);

/// The compliance H of one sensor geometry for any isotropic material, from H built at a few
/// Poisson's ratios (the nodes).
///
/// Why so few builds suffice: with B-bar the element stiffness is G S_dev + K S_vol exactly
/// (CalcHex8Stiffness), so the assembled stiffness is G (S_dev + (K / G) S_vol) and, the
/// boundary conditions being fixed displacements of zero,
///   H(G, K) = h(G / K) / G.
/// Young's modulus is therefore an exact scale, H(E, nu) = H(1, nu) / E, and needs no rebuild;
/// only the ratio s = G / K (equivalently nu) changes H's shape. h(s) = G H is smooth in s down
/// to the incompressible limit s = 0 (the volumetric constraint enters as a penalty 1 / s, so
/// h(s) = h(0) + O(s)), so it is interpolated by the Lagrange polynomial through the nodes in s,
/// not in nu (where nu -> 0.5 crowds the nodes).
class ComplianceFamily {
 public:
  /// Loads (or builds and caches, LoadOrBuildComplianceModel) H at each node's Poisson's ratio,
  /// options.material's Young's modulus; the cache key includes the material, so each node is
  /// cached on its own.
  /// @param poisson_nodes at least 2 distinct valid Poisson's ratios.
  /// @param cache_dir where H is cached; empty: built, not cached.
  /// @throws tac3d::Error if the options or the nodes are invalid.
  ComplianceFamily(const BodyModelOptions& options,
                   std::vector<double> poisson_nodes,
                   const std::string& cache_dir,
                   bool show_progress = false);

  /// H (3N x 3N, mm/N) for the material, interpolated in G / K between the nodes and scaled
  /// by 1 / G; exactly the node's H (scaled by its E / material's E) at a node.
  /// @throws tac3d::Error if the material is invalid or its nu lies outside the nodes' range
  ///   (the interpolation does not extrapolate).
  Eigen::MatrixXd CalcH(const ElasticMaterial& material) const;

  double min_poisson_ratio() const { return poisson_nodes_.front(); }
  double max_poisson_ratio() const { return poisson_nodes_.back(); }
  /// The nodes, increasing.
  const std::vector<double>& poisson_nodes() const { return poisson_nodes_; }
  /// The options of the nodes' models (material: the first node's).
  const BodyModelOptions& options() const { return options_; }
  const std::vector<Eigen::Vector3d>& marker_positions() const { return marker_positions_; }

 private:
  BodyModelOptions options_;
  std::vector<double> poisson_nodes_;
  // G H at each node (mm MPa / N = 1 / mm): h(s) at s = ShearToBulkRatio(node).
  std::vector<Eigen::MatrixXd> shear_scaled_h_;
  std::vector<Eigen::Vector3d> marker_positions_;
};

}  // namespace tac3d::fem
