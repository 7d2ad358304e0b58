#include "tac3d/contact/compliance.h"

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>

#include "tac3d/util/error.h"

namespace tac3d::contact {
namespace {

// First component index and count of a component range.
int First(Components c) { return c == Components::kTangential ? 0 : 2; }
int Count(Components c) { return c == Components::kTangential ? 2 : 1; }

// a * log(b + rho) with the limit 0 at a = 0; log(b + rho) computed without cancellation
// for b < 0 (b + rho = a^2 / (rho - b)).
double ALogBPlusRho(double a, double b, double rho) {
  if (a == 0.0) return 0.0;
  return a * (b >= 0.0 ? std::log(b + rho) : std::log(a * a / (rho - b)));
}

// Primitives F(x, y) with d^2 F / dx dy the kernel; the rectangle's integral is the double
// difference of F over its corners.
double PrimitiveInvRho(double x, double y) {  // 1 / rho
  const double rho = std::hypot(x, y);
  return ALogBPlusRho(x, y, rho) + ALogBPlusRho(y, x, rho);
}
double PrimitiveXXOverRho3(double x, double y) {  // x^2 / rho^3
  return ALogBPlusRho(y, x, std::hypot(x, y));
}
double PrimitiveXYOverRho3(double x, double y) { return -std::hypot(x, y); }  // x y / rho^3
double PrimitiveXOverRho2(double x, double y) {                               // x / rho^2
  const double rho = std::hypot(x, y);
  const double log_term = y == 0.0 ? 0.0 : y * std::log(rho);
  const double atan_term = x == 0.0 ? 0.0 : x * std::atan(y / x);
  return log_term + atan_term;
}

template <typename F>
double OverCell(F f, double x, double y, double dx, double dy) {
  // The cell spans [-dx/2, dx/2] around its centre, so the offset runs over [x - dx/2, x + dx/2].
  const double x1 = x - 0.5 * dx, x2 = x + 0.5 * dx;
  const double y1 = y - 0.5 * dy, y2 = y + 0.5 * dy;
  return f(x2, y2) - f(x1, y2) - f(x2, y1) + f(x1, y1);
}

}  // namespace

void SurfaceGrid::Validate() const {
  if (nx < 3 || ny < 3) {
    throw Error(fmt::format("SurfaceGrid must have nx, ny >= 3, got {} x {}", nx, ny));
  }
  if (!(dx_mm > 0.0 && std::isfinite(dx_mm)) || !(dy_mm > 0.0 && std::isfinite(dy_mm))) {
    throw Error(fmt::format("SurfaceGrid.dx_mm, dy_mm must be > 0, got {}, {}", dx_mm, dy_mm));
  }
}

Eigen::Vector2d SurfaceGrid::node_position_mm(int index) const {
  const int i = index % nx, j = index / nx;
  return {(i - 0.5 * (nx - 1)) * dx_mm, (j - 0.5 * (ny - 1)) * dy_mm};
}

bool SurfaceGrid::is_edge_node(int index) const {
  const int i = index % nx, j = index / nx;
  return i == 0 || j == 0 || i == nx - 1 || j == ny - 1;
}

DenseCompliance::DenseCompliance(const SurfaceGrid& grid, Eigen::MatrixXd c_mm_per_mpa)
    : grid_(grid), c_(std::move(c_mm_per_mpa)) {
  grid_.Validate();
  const int size = 3 * grid_.num_nodes();
  if (c_.rows() != size || c_.cols() != size) {
    throw Error(
        fmt::format("DenseCompliance: the matrix must be {0} x {0} for a {1} x {2} grid, "
                    "got {3} x {4}",
                    size,
                    grid_.nx,
                    grid_.ny,
                    c_.rows(),
                    c_.cols()));
  }
  if (!c_.allFinite()) throw Error("DenseCompliance: the matrix has non-finite entries");
  const double asymmetry = (c_ - c_.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > 1e-9 * c_.cwiseAbs().maxCoeff()) {
    throw Error(fmt::format("DenseCompliance: the matrix is not symmetric (max |C - C^T| = {})",
                            asymmetry));
  }
}

Eigen::MatrixXd DenseCompliance::Apply(Components out,
                                       Components in,
                                       const Eigen::MatrixXd& traction) const {
  const int n = grid_.num_nodes();
  TAC3D_DEMAND(traction.rows() == n && traction.cols() == Count(in));
  const Eigen::Map<const Eigen::VectorXd> p(traction.data(), traction.size());
  Eigen::MatrixXd u(n, Count(out));
  Eigen::Map<Eigen::VectorXd>(u.data(), u.size()).noalias() =
      c_.block(First(out) * n, First(in) * n, Count(out) * n, Count(in) * n) * p;
  return u;
}

double CalcHalfSpaceInfluence(int out,
                              int in,
                              double x_mm,
                              double y_mm,
                              double dx_mm,
                              double dy_mm,
                              const fem::ElasticMaterial& material) {
  TAC3D_DEMAND(out >= 0 && out < 3 && in >= 0 && in < 3);
  const double nu = material.poisson_ratio;
  const double a = (1.0 + nu) / (std::numbers::pi * material.youngs_modulus_mpa);
  const auto cell = [&](auto f) { return OverCell(f, x_mm, y_mm, dx_mm, dy_mm); };
  const auto swapped = [](auto f) { return [f](double x, double y) { return f(y, x); }; };
  if (out == 2 && in == 2) return (1.0 - nu) * a * cell(PrimitiveInvRho);
  if (out < 2 && in < 2) {
    if (out != in) return nu * a * cell(PrimitiveXYOverRho3);
    const double along = out == 0 ? cell(PrimitiveXXOverRho3) : cell(swapped(PrimitiveXXOverRho3));
    return a * ((1.0 - nu) * cell(PrimitiveInvRho) + nu * along);
  }
  // Normal-tangential coupling: odd in the offset, of opposite sign in the two blocks.
  const int t = out < 2 ? out : in;
  const double integral = t == 0 ? cell(PrimitiveXOverRho2) : cell(swapped(PrimitiveXOverRho2));
  const double sign = out < 2 ? -1.0 : 1.0;
  return sign * 0.5 * (1.0 - 2.0 * nu) * a * integral;
}

// Kernel spectra for the circular convolution on the zero-padded grid, one per (out, in) pair,
// in OpenCV's packed (CCS) real-DFT format.
struct HalfSpaceCompliance::Spectra {
  int rows = 0, cols = 0;
  cv::Mat kernel[3][3];
};

HalfSpaceCompliance::HalfSpaceCompliance(const SurfaceGrid& grid,
                                         const fem::ElasticMaterial& material)
    : grid_(grid), material_(material), spectra_(std::make_unique<Spectra>()) {
  grid_.Validate();
  material_.Validate();
  // Offsets span -(n - 1)..(n - 1): padding to >= 2n - 1 makes the circular convolution linear.
  spectra_->rows = cv::getOptimalDFTSize(2 * grid_.ny - 1);
  spectra_->cols = cv::getOptimalDFTSize(2 * grid_.nx - 1);
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      cv::Mat k = cv::Mat::zeros(spectra_->rows, spectra_->cols, CV_64F);
      for (int dj = -(grid_.ny - 1); dj < grid_.ny; ++dj) {
        for (int di = -(grid_.nx - 1); di < grid_.nx; ++di) {
          const int r = (dj + spectra_->rows) % spectra_->rows;
          const int c = (di + spectra_->cols) % spectra_->cols;
          k.at<double>(r, c) = CalcHalfSpaceInfluence(
              out, in, di * grid_.dx_mm, dj * grid_.dy_mm, grid_.dx_mm, grid_.dy_mm, material_);
        }
      }
      cv::dft(k, spectra_->kernel[out][in]);
    }
  }
}

HalfSpaceCompliance::~HalfSpaceCompliance() = default;

Eigen::MatrixXd HalfSpaceCompliance::Apply(Components out,
                                           Components in,
                                           const Eigen::MatrixXd& traction) const {
  const int n = grid_.num_nodes();
  TAC3D_DEMAND(traction.rows() == n && traction.cols() == Count(in));
  // Per-thread buffers: solvers call this thousands of times, and freeing and reallocating
  // the padded images each time costs more than the transforms (heap trimming).
  thread_local struct { cv::Mat padded, traction_spectra[2], sum, product, field; } work;
  for (int c = 0; c < Count(in); ++c) {
    work.padded.create(spectra_->rows, spectra_->cols, CV_64F);
    work.padded.setTo(0.0);
    // Node j * nx + i is row j, column i of a row-major ny x nx image.
    cv::Mat(grid_.ny, grid_.nx, CV_64F, const_cast<double*>(traction.col(c).data()))
        .copyTo(work.padded(cv::Rect(0, 0, grid_.nx, grid_.ny)));
    cv::dft(work.padded, work.traction_spectra[c]);
  }
  Eigen::MatrixXd u(n, Count(out));
  for (int o = 0; o < Count(out); ++o) {
    for (int c = 0; c < Count(in); ++c) {
      const cv::Mat& kernel = spectra_->kernel[First(out) + o][First(in) + c];
      cv::mulSpectrums(work.traction_spectra[c], kernel, c == 0 ? work.sum : work.product, 0);
      if (c > 0) work.sum += work.product;
    }
    cv::dft(work.sum, work.field, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
    work.field(cv::Rect(0, 0, grid_.nx, grid_.ny))
        .copyTo(cv::Mat(grid_.ny, grid_.nx, CV_64F, u.col(o).data()));
  }
  return u;
}

Eigen::MatrixXd HalfSpaceCompliance::CalcDenseMatrix() const {
  const int n = grid_.num_nodes();
  Eigen::MatrixXd c(3 * n, 3 * n);
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      for (int s = 0; s < n; ++s) {
        for (int f = 0; f < n; ++f) {
          const Eigen::Vector2d d = grid_.node_position_mm(f) - grid_.node_position_mm(s);
          c(out * n + f, in * n + s) =
              CalcHalfSpaceInfluence(out, in, d.x(), d.y(), grid_.dx_mm, grid_.dy_mm, material_);
        }
      }
    }
  }
  return c;
}

}  // namespace tac3d::contact
