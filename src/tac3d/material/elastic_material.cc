#include "tac3d/material/elastic_material.h"

#include <fmt/format.h>

#include "tac3d/util/error.h"

namespace tac3d {

void ElasticMaterial::Validate() const {
  if (!(youngs_modulus_mpa > 0.0)) {
    throw Error(
        fmt::format("ElasticMaterial.youngs_modulus_mpa must be > 0, got {}", youngs_modulus_mpa));
  }
  if (!(poisson_ratio > -1.0 && poisson_ratio <= 0.4999)) {
    throw Error(fmt::format("ElasticMaterial.poisson_ratio must be in (-1, 0.4999], got {}",
                            poisson_ratio));
  }
}

double ElasticMaterial::shear_modulus() const {
  return youngs_modulus_mpa / (2.0 * (1.0 + poisson_ratio));
}

double ElasticMaterial::bulk_modulus() const {
  return youngs_modulus_mpa / (3.0 * (1.0 - 2.0 * poisson_ratio));
}

double ElasticMaterial::constrained_modulus() const {
  const double nu = poisson_ratio;
  return youngs_modulus_mpa * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu));
}

}  // namespace tac3d
