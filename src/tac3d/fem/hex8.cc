#include "tac3d/fem/hex8.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

constexpr std::array<std::array<double, 3>, 8> kCorners = {{{-1, -1, -1},
                                                            {1, -1, -1},
                                                            {1, 1, -1},
                                                            {-1, 1, -1},
                                                            {-1, -1, 1},
                                                            {1, -1, 1},
                                                            {1, 1, 1},
                                                            {-1, 1, 1}}};

// The 2-point Gauss rule on [-1, 1] (weights 1), tensorised to 8 points.
std::array<Eigen::Vector3d, 8> GaussPoints2() {
  const double g = 1.0 / std::sqrt(3.0);
  std::array<Eigen::Vector3d, 8> points;
  for (int a = 0; a < 8; ++a) {
    points[a] = g * Eigen::Vector3d(kCorners[a][0], kCorners[a][1], kCorners[a][2]);
  }
  return points;
}

// Jacobian J(i, j) = dx_j / dxi_i.
Eigen::Matrix3d Jacobian(const Hex8Nodes& x, const Eigen::Matrix<double, 8, 3>& dn_dxi) {
  return dn_dxi.transpose() * x;
}

struct GaussData {
  Eigen::Matrix<double, 8, 3> dn_dx;  // dN_a / dx_i
  double weight_volume;               // Gauss weight * det J
};

std::array<GaussData, 8> CalcGaussData(const Hex8Nodes& x) {
  static const std::array<Eigen::Vector3d, 8> kGauss = GaussPoints2();
  std::array<GaussData, 8> data;
  for (int g = 0; g < 8; ++g) {
    const Eigen::Matrix<double, 8, 3> dn_dxi = CalcHex8ShapeDerivatives(kGauss[g]);
    const Eigen::Matrix3d jac = Jacobian(x, dn_dxi);
    const double det = jac.determinant();
    TAC3D_DEMAND(det > 0.0);
    // dN/dxi = dN/dx J^T, so dN/dx = dN/dxi J^-T.
    data[g].dn_dx = dn_dxi * jac.inverse().transpose();
    data[g].weight_volume = det;
  }
  return data;
}

// The element's mean of dN_a/dx_i over its volume (the B-bar volumetric operator), and volume.
Eigen::Matrix<double, 8, 3> MeanShapeGradient(const std::array<GaussData, 8>& data,
                                              double* volume) {
  Eigen::Matrix<double, 8, 3> mean = Eigen::Matrix<double, 8, 3>::Zero();
  *volume = 0.0;
  for (const GaussData& d : data) {
    mean += d.weight_volume * d.dn_dx;
    *volume += d.weight_volume;
  }
  return mean / *volume;
}

}  // namespace

Eigen::Matrix<double, 8, 1> CalcHex8Shape(const Eigen::Vector3d& xi) {
  Eigen::Matrix<double, 8, 1> n;
  for (int a = 0; a < 8; ++a) {
    n(a) = 0.125 * (1.0 + kCorners[a][0] * xi(0)) * (1.0 + kCorners[a][1] * xi(1)) *
           (1.0 + kCorners[a][2] * xi(2));
  }
  return n;
}

Eigen::Matrix<double, 8, 3> CalcHex8ShapeDerivatives(const Eigen::Vector3d& xi) {
  Eigen::Matrix<double, 8, 3> d;
  for (int a = 0; a < 8; ++a) {
    const double fx = 1.0 + kCorners[a][0] * xi(0);
    const double fy = 1.0 + kCorners[a][1] * xi(1);
    const double fz = 1.0 + kCorners[a][2] * xi(2);
    d(a, 0) = 0.125 * kCorners[a][0] * fy * fz;
    d(a, 1) = 0.125 * kCorners[a][1] * fx * fz;
    d(a, 2) = 0.125 * kCorners[a][2] * fx * fy;
  }
  return d;
}

double CalcHex8JacobianDeterminant(const Hex8Nodes& x, const Eigen::Vector3d& xi) {
  return Jacobian(x, CalcHex8ShapeDerivatives(xi)).determinant();
}

double CalcHex8MinJacobianDeterminant(const Hex8Nodes& x) {
  static const std::array<Eigen::Vector3d, 8> kGauss = GaussPoints2();
  double min_det = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 8; ++a) {
    const Eigen::Vector3d corner(kCorners[a][0], kCorners[a][1], kCorners[a][2]);
    min_det = std::min(min_det, CalcHex8JacobianDeterminant(x, corner));
    min_det = std::min(min_det, CalcHex8JacobianDeterminant(x, kGauss[a]));
  }
  return min_det;
}

Hex8Matrix CalcHex8Stiffness(const Hex8Nodes& x, const ElasticMaterial& material) {
  const double mu = material.shear_modulus();
  const double bulk = material.bulk_modulus();
  const std::array<GaussData, 8> data = CalcGaussData(x);

  // Deviatoric part: the isotropic stiffness with lambda replaced by -2 mu / 3,
  // K_ab_ij = -2mu/3 dNa_i dNb_j + mu (delta_ij grad Na . grad Nb + dNa_j dNb_i).
  Hex8Matrix k = Hex8Matrix::Zero();
  for (const GaussData& d : data) {
    const Eigen::Matrix<double, 8, 8> dots = d.dn_dx * d.dn_dx.transpose();
    for (int a = 0; a < 8; ++a) {
      for (int b = 0; b < 8; ++b) {
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) {
            double v = -2.0 / 3.0 * d.dn_dx(a, i) * d.dn_dx(b, j) + d.dn_dx(a, j) * d.dn_dx(b, i);
            if (i == j) v += dots(a, b);
            k(3 * a + i, 3 * b + j) += d.weight_volume * mu * v;
          }
        }
      }
    }
  }
  // Volumetric part from the mean dilatation: K V b_mean b_mean^T.
  double volume = 0.0;
  const Eigen::Matrix<double, 8, 3> mean = MeanShapeGradient(data, &volume);
  const Eigen::Matrix<double, 3, 8> mean_t = mean.transpose();
  const Hex8Vector b_mean = mean_t.reshaped();  // DOF order 3 a + i
  k += bulk * volume * b_mean * b_mean.transpose();
  return k;
}

Hex8Vector CalcHex8VolumeChange(const Hex8Nodes& x, double* volume_mm3) {
  const Eigen::Matrix<double, 8, 3> mean = MeanShapeGradient(CalcGaussData(x), volume_mm3);
  const Eigen::Matrix<double, 3, 8> mean_t = mean.transpose();
  return *volume_mm3 * mean_t.reshaped();
}

Eigen::Matrix3d CalcHex8Stress(const Hex8Nodes& x,
                               const Hex8Vector& u,
                               const ElasticMaterial& material,
                               const Eigen::Vector3d& xi) {
  const std::array<GaussData, 8> data = CalcGaussData(x);
  double volume = 0.0;
  const Eigen::Matrix<double, 8, 3> mean = MeanShapeGradient(data, &volume);
  const Eigen::Matrix<double, 3, 8> u_nodes = u.reshaped(3, 8);

  const Eigen::Matrix<double, 8, 3> dn_dxi = CalcHex8ShapeDerivatives(xi);
  const Eigen::Matrix<double, 8, 3> dn_dx = dn_dxi * Jacobian(x, dn_dxi).inverse().transpose();
  const Eigen::Matrix3d grad = u_nodes * dn_dx;  // du_i / dx_j
  const Eigen::Matrix3d strain = 0.5 * (grad + grad.transpose());
  const double mean_dilatation = (u_nodes * mean).trace();

  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d deviator = strain - strain.trace() / 3.0 * identity;
  return 2.0 * material.shear_modulus() * deviator +
         material.bulk_modulus() * mean_dilatation * identity;
}

TopFaceIntegrals IntegrateHex8TopFace(
    const Hex8Nodes& x, double xi_min, double xi_max, double eta_min, double eta_max) {
  TAC3D_DEMAND(-1.0 <= xi_min && xi_min <= xi_max && xi_max <= 1.0);
  TAC3D_DEMAND(-1.0 <= eta_min && eta_min <= eta_max && eta_max <= 1.0);
  // 3-point Gauss rule on [-1, 1].
  const std::array<double, 3> points = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
  const std::array<double, 3> weights = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  const double half_xi = 0.5 * (xi_max - xi_min);
  const double half_eta = 0.5 * (eta_max - eta_min);

  TopFaceIntegrals result;
  for (int p = 0; p < 3; ++p) {
    for (int q = 0; q < 3; ++q) {
      const Eigen::Vector3d xi(
          xi_min + half_xi * (points[p] + 1.0), eta_min + half_eta * (points[q] + 1.0), 1.0);
      const Eigen::Matrix3d jac = Jacobian(x, CalcHex8ShapeDerivatives(xi));
      const double area_scale = jac.row(0).cross(jac.row(1)).norm();
      const double w = weights[p] * weights[q] * half_xi * half_eta * area_scale;
      result.shape_integrals += w * CalcHex8Shape(xi).tail<4>();
      result.area_mm2 += w;
    }
  }
  return result;
}

}  // namespace tac3d::fem
