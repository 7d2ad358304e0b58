#include "tac3d/contact/compliance.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
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
                              const ElasticMaterial& material) {
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

SampledKernel SampledKernel::Zero(const SurfaceGrid& grid) {
  SampledKernel kernel;
  for (auto& row : kernel.k) {
    for (Eigen::MatrixXd& k : row) k = Eigen::MatrixXd::Zero(2 * grid.ny - 1, 2 * grid.nx - 1);
  }
  return kernel;
}

double& SampledKernel::at(int out, int in, int di, int dj) {
  Eigen::MatrixXd& m = k[out][in];
  return m(dj + (m.rows() - 1) / 2, di + (m.cols() - 1) / 2);
}

double SampledKernel::at(int out, int in, int di, int dj) const {
  const Eigen::MatrixXd& m = k[out][in];
  return m(dj + (m.rows() - 1) / 2, di + (m.cols() - 1) / 2);
}

// Kernel spectra for the circular convolution on the zero-padded grid, one per (out, in) pair,
// in OpenCV's packed (CCS) real-DFT format.
struct ConvolutionCompliance::Spectra {
  int rows = 0, cols = 0;
  cv::Mat kernel[3][3];
};

namespace {

// The kernel wrapped onto the padded rows x cols torus (offset d at index d mod size).
cv::Mat WrapKernel(const Eigen::MatrixXd& k, int rows, int cols) {
  cv::Mat wrapped = cv::Mat::zeros(rows, cols, CV_64F);
  const int hy = (k.rows() - 1) / 2, hx = (k.cols() - 1) / 2;
  for (int dj = -hy; dj <= hy; ++dj) {
    for (int di = -hx; di <= hx; ++di) {
      wrapped.at<double>((dj + rows) % rows, (di + cols) % cols) = k(dj + hy, di + hx);
    }
  }
  return wrapped;
}

}  // namespace

ConvolutionCompliance::ConvolutionCompliance(const SurfaceGrid& grid,
                                             const SampledKernel& kernel,
                                             double clamp_floor)
    : grid_(grid), kernel_(kernel), spectra_(std::make_unique<Spectra>()) {
  grid_.Validate();
  if (!(clamp_floor >= 0.0 && clamp_floor < 1.0)) {
    throw Error(fmt::format("ConvolutionCompliance: clamp_floor must be in [0, 1), got {}",
                            clamp_floor));
  }
  const int hx = grid_.nx - 1, hy = grid_.ny - 1;
  double largest = 0.0;
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      const Eigen::MatrixXd& k = kernel_.k[out][in];
      if (k.rows() != 2 * hy + 1 || k.cols() != 2 * hx + 1) {
        throw Error(fmt::format("ConvolutionCompliance: kernel ({}, {}) is {} x {}, expected {} x {}",
                                out, in, k.rows(), k.cols(), 2 * hy + 1, 2 * hx + 1));
      }
      if (!k.allFinite()) {
        throw Error(fmt::format("ConvolutionCompliance: kernel ({}, {}) has non-finite entries",
                                out, in));
      }
      largest = std::max(largest, k.cwiseAbs().maxCoeff());
    }
  }
  double asymmetry = 0.0;
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      // K_ab(d) = K_ba(-d): the reversed kernel.
      asymmetry = std::max(
          asymmetry,
          (kernel_.k[out][in] - kernel_.k[in][out].reverse()).cwiseAbs().maxCoeff());
    }
  }
  if (asymmetry > 1e-9 * largest) {
    throw Error(fmt::format(
        "ConvolutionCompliance: the kernel is not reciprocal (max |K_ab(d) - K_ba(-d)| = {} mm/MPa)",
        asymmetry));
  }

  // Offsets span -(n - 1)..(n - 1): padding to >= 2n - 1 makes the circular convolution linear.
  const int rows = cv::getOptimalDFTSize(2 * grid_.ny - 1);
  const int cols = cv::getOptimalDFTSize(2 * grid_.nx - 1);
  spectra_->rows = rows;
  spectra_->cols = cols;

  // The symbol at every frequency (full complex spectra).
  cv::Mat full[3][3];
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      cv::dft(WrapKernel(kernel_.k[out][in], rows, cols), full[out][in], cv::DFT_COMPLEX_OUTPUT);
    }
  }
  std::vector<Eigen::Vector3d> eigenvalues(static_cast<size_t>(rows) * cols);
  std::vector<Eigen::Matrix3cd> eigenvectors(eigenvalues.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3cd> solver;
  symbol_report_.num_frequencies = rows * cols;
  symbol_report_.min_eigenvalue = std::numeric_limits<double>::infinity();
  symbol_report_.max_eigenvalue = -std::numeric_limits<double>::infinity();
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      Eigen::Matrix3cd s;
      for (int out = 0; out < 3; ++out) {
        for (int in = 0; in < 3; ++in) {
          const cv::Vec2d v = full[out][in].at<cv::Vec2d>(r, c);
          s(out, in) = {v[0], v[1]};
        }
      }
      solver.compute(0.5 * (s + s.adjoint()));
      const size_t f = static_cast<size_t>(r) * cols + c;
      eigenvalues[f] = solver.eigenvalues();
      eigenvectors[f] = solver.eigenvectors();
      symbol_report_.min_eigenvalue = std::min(symbol_report_.min_eigenvalue, eigenvalues[f](0));
      symbol_report_.max_eigenvalue = std::max(symbol_report_.max_eigenvalue, eigenvalues[f](2));
    }
  }
  if (clamp_floor > 0.0) {
    const double floor = clamp_floor * symbol_report_.max_eigenvalue;
    for (size_t f = 0; f < eigenvalues.size(); ++f) {
      symbol_report_.num_clamped += (eigenvalues[f].array() < floor).count();
    }
    if (symbol_report_.num_clamped > 0) {
      for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < cols; ++c) {
          const size_t f = static_cast<size_t>(r) * cols + c;
          const Eigen::Vector3d clamped = eigenvalues[f].cwiseMax(floor);
          const Eigen::Matrix3cd s =
              eigenvectors[f] * clamped.asDiagonal() * eigenvectors[f].adjoint();
          for (int out = 0; out < 3; ++out) {
            for (int in = 0; in < 3; ++in) {
              full[out][in].at<cv::Vec2d>(r, c) = {s(out, in).real(), s(out, in).imag()};
            }
          }
        }
      }
      // Back to the kernel on the grid's offsets (the clamped circulant's, restricted).
      for (int out = 0; out < 3; ++out) {
        for (int in = 0; in < 3; ++in) {
          cv::Mat wrapped;
          cv::dft(full[out][in], wrapped, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
          for (int dj = -hy; dj <= hy; ++dj) {
            for (int di = -hx; di <= hx; ++di) {
              kernel_.at(out, in, di, dj) = wrapped.at<double>((dj + rows) % rows, (di + cols) % cols);
            }
          }
        }
      }
    }
  }
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      cv::dft(WrapKernel(kernel_.k[out][in], rows, cols), spectra_->kernel[out][in]);
    }
  }
}

ConvolutionCompliance::~ConvolutionCompliance() = default;

Eigen::MatrixXd ConvolutionCompliance::Apply(Components out,
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
    cv::dft(work.padded, work.traction_spectra[c], 0, grid_.ny);
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

std::shared_ptr<const ComplianceOperator> ConvolutionCompliance::Window(int nx, int ny) const {
  TAC3D_DEMAND(nx >= 3 && ny >= 3 && nx <= grid_.nx && ny <= grid_.ny);
  SurfaceGrid window = grid_;
  window.nx = nx;
  window.ny = ny;
  SampledKernel cropped = SampledKernel::Zero(window);
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      cropped.k[out][in] = kernel_.k[out][in].block(grid_.ny - ny, grid_.nx - nx, 2 * ny - 1, 2 * nx - 1);
    }
  }
  return std::make_shared<ConvolutionCompliance>(window, cropped);
}

Eigen::MatrixXd ConvolutionCompliance::CalcDenseMatrix() const {
  const int n = grid_.num_nodes();
  Eigen::MatrixXd c(3 * n, 3 * n);
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      for (int s = 0; s < n; ++s) {
        for (int f = 0; f < n; ++f) {
          const int di = f % grid_.nx - s % grid_.nx, dj = f / grid_.nx - s / grid_.nx;
          c(out * n + f, in * n + s) = kernel_.at(out, in, di, dj);
        }
      }
    }
  }
  return c;
}

namespace {

SampledKernel HalfSpaceKernel(const SurfaceGrid& grid, const ElasticMaterial& material) {
  grid.Validate();
  material.Validate();
  SampledKernel kernel = SampledKernel::Zero(grid);
  for (int out = 0; out < 3; ++out) {
    for (int in = 0; in < 3; ++in) {
      for (int dj = -(grid.ny - 1); dj < grid.ny; ++dj) {
        for (int di = -(grid.nx - 1); di < grid.nx; ++di) {
          kernel.at(out, in, di, dj) = CalcHalfSpaceInfluence(
              out, in, di * grid.dx_mm, dj * grid.dy_mm, grid.dx_mm, grid.dy_mm, material);
        }
      }
    }
  }
  return kernel;
}

}  // namespace

HalfSpaceCompliance::HalfSpaceCompliance(const SurfaceGrid& grid,
                                         const ElasticMaterial& material)
    : convolution_(grid, HalfSpaceKernel(grid, material)) {}

}  // namespace tac3d::contact
