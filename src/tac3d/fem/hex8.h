#pragma once

#include <Eigen/Core>

#include "tac3d/material/elastic_material.h"

namespace tac3d::fem {

/// Corner coordinates of an 8-node hexahedron, one node a row (mm). Node order is the
/// usual one: parametric corners (-1,-1,-1), (1,-1,-1), (1,1,-1), (-1,1,-1), then the same
/// four at zeta = +1. The face zeta = +1 (nodes 4..7) is the element's "top" face.
using Hex8Nodes = Eigen::Matrix<double, 8, 3>;
/// Nodal values of an 8-node hexahedron in DOF order (node a, component c) -> 3 * a + c.
using Hex8Vector = Eigen::Matrix<double, 24, 1>;
using Hex8Matrix = Eigen::Matrix<double, 24, 24>;

/// Trilinear shape functions N_a at the parametric point xi in [-1, 1]^3.
Eigen::Matrix<double, 8, 1> CalcHex8Shape(const Eigen::Vector3d& xi);

/// Their parametric derivatives dN_a / dxi_i, row a, column i.
Eigen::Matrix<double, 8, 3> CalcHex8ShapeDerivatives(const Eigen::Vector3d& xi);

/// The Jacobian determinant det(dx/dxi) at xi; positive for a valid element.
double CalcHex8JacobianDeterminant(const Hex8Nodes& x, const Eigen::Vector3d& xi);

/// The smallest Jacobian determinant over the 8 corners and the 8 Gauss points.
double CalcHex8MinJacobianDeterminant(const Hex8Nodes& x);

/// The element stiffness matrix (N/mm), B-bar (mean dilatation, Hughes 1980): the deviatoric
/// part with 2x2x2 Gauss points, the volumetric part with the element's mean volumetric strain,
/// K = int B^T D_dev B dV + K_bulk V b_mean b_mean^T. Free of volumetric locking as nu -> 1/2,
/// and it passes the patch test on distorted elements.
/// @pre positive Jacobian at every Gauss point (TAC3D_DEMAND).
Hex8Matrix CalcHex8Stiffness(const Hex8Nodes& x, const ElasticMaterial& material);

/// The element's volume-change operator of the B-bar stiffness: the row V b_mean (mm^2, DOF
/// order 3 a + i), so that its product with the nodal displacements is the volume change
/// int div u dV (mm^3), and the volumetric part of CalcHex8Stiffness is K_bulk / V times its
/// outer product with itself. The mixed solver's pressure equation (ElasticSolver).
/// @param volume_mm3 the element's volume V.
/// @pre positive Jacobian at every Gauss point (TAC3D_DEMAND).
Hex8Vector CalcHex8VolumeChange(const Hex8Nodes& x, double* volume_mm3);

/// The Cauchy stress (MPa) at xi for nodal displacements u (mm), consistent with the B-bar
/// stiffness: deviatoric part from the local strain, pressure from the element's mean
/// volumetric strain.
Eigen::Matrix3d CalcHex8Stress(const Hex8Nodes& x,
                               const Hex8Vector& u,
                               const ElasticMaterial& material,
                               const Eigen::Vector3d& xi);

/// Integrals over part of the top face (zeta = +1) of an element.
struct TopFaceIntegrals {
  /// int N_a dA for the face's nodes a = 4..7 (mm^2).
  Eigen::Vector4d shape_integrals = Eigen::Vector4d::Zero();
  /// int dA (mm^2), the sum of shape_integrals.
  double area_mm2 = 0.0;
};

/// Integrates over the parametric rectangle [xi_min, xi_max] x [eta_min, eta_max] of the
/// top face, on the curved face itself (3x3 Gauss points). A uniform traction t over that part
/// of the face gives the nodal forces shape_integrals(a) * t.
/// @pre -1 <= xi_min <= xi_max <= 1, the same for eta.
TopFaceIntegrals IntegrateHex8TopFace(
    const Hex8Nodes& x, double xi_min, double xi_max, double eta_min, double eta_max);

}  // namespace tac3d::fem
