#pragma once

namespace tac3d {

/// An isotropic linear elastic material.
struct ElasticMaterial {
  /// Young's modulus E (MPa = N/mm^2).
  double youngs_modulus_mpa = 1.0;
  /// Poisson's ratio nu; up to 0.4999 (the element is locking-free, see CalcHex8Stiffness).
  double poisson_ratio = 0.48;

  /// @throws tac3d::Error naming the field and its bound: E > 0, -1 < nu <= 0.4999.
  void Validate() const;
  /// Shear modulus G = E / (2 (1 + nu)) (MPa).
  double shear_modulus() const;
  /// Bulk modulus K = E / (3 (1 - 2 nu)) (MPa).
  double bulk_modulus() const;
  /// Constrained (oedometric) modulus E (1 - nu) / ((1 + nu)(1 - 2 nu)) (MPa): stress over
  /// strain in uniaxial strain, the stiffness of a laterally confined layer.
  double constrained_modulus() const;
};

}  // namespace tac3d
