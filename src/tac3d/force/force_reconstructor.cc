#include "tac3d/force/force_reconstructor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "tac3d/util/error.h"
#include "tac3d/util/shared_cache.h"

namespace tac3d {
namespace {

// A rows x cols matrix on grow-only storage: allocates only when it needs more than ever before.
Eigen::Map<Eigen::MatrixXd> GrowOnlyMatrix(Eigen::VectorXd* storage, Eigen::Index rows,
                                           Eigen::Index cols) {
  if (storage->size() < rows * cols) storage->resize(std::max(rows * cols, 2 * storage->size()));
  return {storage->data(), rows, cols};
}

void ValidateGains(const Eigen::Vector3d& gains, const char* where) {
  for (int axis = 0; axis < 3; ++axis) {
    if (!(gains(axis) > 0.0 && gains(axis) <= kMaxForceGain)) {
      throw Error(fmt::format("{}.gains.{} must be in (0, {}], got {}", where, "xyz"[axis],
                              kMaxForceGain, gains(axis)));
    }
  }
}

void ValidateWeight(double weight) {
  if (!(weight > 0.0 && std::isfinite(weight))) {
    throw Error(
        fmt::format("ForceReconstructorOptions.weight must be > 0 and finite, got {}", weight));
  }
}

}  // namespace

void ForceReconstructorOptions::Validate() const {
  ValidateWeight(weight);
  ValidateGains(gains, "ForceReconstructorOptions");
  const auto require = [](bool ok, const char* field, const char* bound, double value) {
    if (!ok) throw Error(fmt::format("ForceReconstructorOptions.{} must be {}, got {}", field, bound, value));
  };
  require(support_threshold_n >= 0.0 && std::isfinite(support_threshold_n), "support_threshold_n",
          ">= 0 and finite", support_threshold_n);
  require(support_margin_pitches >= 0.0 && std::isfinite(support_margin_pitches),
          "support_margin_pitches", ">= 0 and finite", support_margin_pitches);
  require(support_weight > 0.0 && std::isfinite(support_weight), "support_weight", "> 0 and finite",
          support_weight);
  require(max_support_markers >= 1, "max_support_markers", ">= 1", max_support_markers);
}

Eigen::Vector3d ForceFrame::MarkerForce(int i) const {
  const int n = num_markers();
  TAC3D_DEMAND(i >= 0 && i < n);
  return {forces_n(i), forces_n(n + i), forces_n(2 * n + i)};
}

TikhonovInverse::TikhonovInverse(std::shared_ptr<const Eigen::MatrixXd> h, double weight)
    : h_(std::move(h)), weight_(weight) {
  if (!h_ || h_->rows() == 0 || h_->rows() != h_->cols()) {
    throw Error(fmt::format("TikhonovInverse: H must be square and not empty, got {} x {}",
                            h_ ? h_->rows() : 0, h_ ? h_->cols() : 0));
  }
  ValidateWeight(weight_);
  const Eigen::MatrixXd& hm = *h_;
  const Eigen::Index n = hm.rows();
  if (!hm.allFinite()) throw Error("TikhonovInverse: H has a non-finite entry");
  // Far above H^T H's eigenvalues, w I swamps the data term and every force is ~0.
  const double mean_eigenvalue = hm.squaredNorm() / static_cast<double>(n);
  if (weight_ > kMaxWeightToMeanEigenvalue * mean_eigenvalue) {
    throw Error(fmt::format(
        "TikhonovInverse: weight w = {} (mm/N)^2 is more than {:g} times H^T H's mean eigenvalue "
        "({:.3g}): the regularisation would drive every force to ~0",
        weight_, kMaxWeightToMeanEigenvalue, mean_eigenvalue));
  }
  // H^T H + w I, lower triangle; H^T H is kept for the contact-support re-solve.
  hth_ = Eigen::MatrixXd::Identity(n, n) * weight_;
  hth_.selfadjointView<Eigen::Lower>().rankUpdate(hm.transpose());
  const Eigen::LLT<Eigen::MatrixXd> factor(hth_);
  if (factor.info() != Eigen::Success) {
    throw Error(fmt::format("TikhonovInverse: H^T H + w I is not positive definite in double "
                            "precision with w = {} (mm/N)^2; choose a larger weight",
                            weight_));
  }
  hth_.diagonal().array() -= weight_;
  k_double_ = factor.solve(hm.transpose());
  k_ = k_double_.cast<float>();
  influence_.noalias() = hm * k_double_;
  influence_ = 0.5 * (influence_ + influence_.transpose()).eval();
}

std::shared_ptr<const TikhonovInverse> SharedTikhonovInverse(
    const std::shared_ptr<const Eigen::MatrixXd>& h, double weight) {
  ValidateWeight(weight);  // a NaN would break the cache's ordering of its keys
  // Keyed by H's address: the inverse holds H, so no other matrix can take that address while
  // the inverse lives.
  static SharedCache<std::pair<const Eigen::MatrixXd*, double>, TikhonovInverse> inverses;
  return inverses.Get({h.get(), weight},
                      [&] { return std::make_shared<const TikhonovInverse>(h, weight); });
}

ForceReconstructor::ForceReconstructor(const Eigen::MatrixXd& h,
                                       std::vector<Eigen::Vector3d> marker_positions_mm,
                                       const ForceReconstructorOptions& options)
    : ForceReconstructor(std::make_shared<const Eigen::MatrixXd>(h),
                         std::move(marker_positions_mm), options) {}

ForceReconstructor::ForceReconstructor(const std::shared_ptr<const Eigen::MatrixXd>& h,
                                       std::vector<Eigen::Vector3d> marker_positions_mm,
                                       const ForceReconstructorOptions& options)
    : num_markers_(static_cast<int>(marker_positions_mm.size())),
      marker_positions_(std::move(marker_positions_mm)),
      options_(options) {
  options_.Validate();
  const int n = 3 * num_markers_;
  if (num_markers_ == 0 || !h || h->rows() != n || h->cols() != n) {
    throw Error(fmt::format("ForceReconstructor: H must be 3N x 3N = {} x {} for N = {} markers, "
                            "got {} x {}",
                            n, n, num_markers_, h ? h->rows() : 0, h ? h->cols() : 0));
  }
  inverse_ = SharedTikhonovInverse(h, options_.weight);
  d_work_.resize(n);
  f_work_.resize(n);
  z_work_.resize(n);
  invalid_.reserve(num_markers_);
  invalid_rows_.reserve(n);
  cached_invalid_.reserve(num_markers_);

  // The support's neighbourhoods, in marker pitches: the pitch is the smallest distance between
  // two markers in the sensor's (x, y).
  double pitch = std::numeric_limits<double>::infinity();
  for (int i = 0; i < num_markers_; ++i) {
    for (int j = i + 1; j < num_markers_; ++j) {
      const double distance = (marker_positions_[i] - marker_positions_[j]).head<2>().norm();
      if (distance > 0.0) pitch = std::min(pitch, distance);
    }
  }
  const double margin = std::isfinite(pitch) ? options_.support_margin_pitches * pitch * 1.001 : 0.0;
  support_neighbours_.resize(num_markers_);
  for (int i = 0; i < num_markers_; ++i) {
    for (int j = 0; j < num_markers_; ++j) {
      if ((marker_positions_[i] - marker_positions_[j]).head<2>().norm() <= margin || i == j) {
        support_neighbours_[i].push_back(j);
      }
    }
  }
  const int max_support = std::min(options_.max_support_markers, num_markers_);
  in_support_.resize(num_markers_);
  support_.reserve(num_markers_);
  factored_support_.reserve(num_markers_);
  factored_support_invalid_.reserve(num_markers_);
  support_rows_.reserve(3 * num_markers_);
  support_matrix_.resize(3 * max_support, 3 * max_support);
  support_rhs_.resize(3 * max_support);
  d_valid_.resize(n);
}

void ForceReconstructor::set_gains(const Eigen::Vector3d& gains) {
  ValidateGains(gains, "ForceReconstructor::set_gains");
  options_.gains = gains;
}

void ForceReconstructor::FactorRestrictedProblem() {
  const int r = static_cast<int>(invalid_rows_.size());
  Eigen::Map<Eigen::MatrixXd> a = GrowOnlyMatrix(&restricted_storage_, r, r);
  for (int c = 0; c < r; ++c) {
    const double* column = inverse_->influence().col(invalid_rows_[c]).data();
    for (int k = c; k < r; ++k) a(k, c) = -column[invalid_rows_[k]];
    a(c, c) += 1.0;
  }
  Eigen::Ref<Eigen::MatrixXd> a_ref(a);
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> factor(a_ref);
  restricted_ok_ = factor.info() == Eigen::Success;
  cached_invalid_ = invalid_;
}

bool ForceReconstructor::RefineOnSupport(ForceFrame* frame) {
  const int m = num_markers_;
  std::fill(in_support_.begin(), in_support_.end(), 0);
  for (int i = 0; i < m; ++i) {
    if (-frame->forces_n(2 * m + i) <= options_.support_threshold_n) continue;
    for (int j : support_neighbours_[i]) in_support_[j] = 1;
  }
  support_.clear();
  for (int i = 0; i < m; ++i) {
    if (in_support_[i]) support_.push_back(i);
  }
  const int s = static_cast<int>(support_.size());
  if (s == 0 || s > options_.max_support_markers) return false;
  support_rows_.clear();
  for (int axis = 0; axis < 3; ++axis) {
    for (int i : support_) support_rows_.push_back(axis * m + i);
  }
  const int n = 3 * s;
  if (support_ != factored_support_ || invalid_ != factored_support_invalid_) {
    factored_support_ = support_;
    factored_support_invalid_ = invalid_;
    support_factor_ok_ = FactorSupportProblem();
  }
  if (!support_factor_ok_) return false;
  Eigen::Ref<Eigen::VectorXd> x = support_rhs_.head(n);
  // Row j of H^T is column j of H.
  const Eigen::MatrixXd& h = inverse_->h();
  for (int k = 0; k < n; ++k) x(k) = h.col(support_rows_[k]).dot(d_valid_);
  const auto l = support_matrix_.topLeftCorner(n, n).triangularView<Eigen::Lower>();
  l.solveInPlace(x);
  l.adjoint().solveInPlace(x);
  frame->forces_n.setZero();
  for (int k = 0; k < n; ++k) frame->forces_n(support_rows_[k]) = x(k);
  frame->num_support_markers = s;
  return true;
}

bool ForceReconstructor::FactorSupportProblem() {
  const int n = static_cast<int>(support_rows_.size());
  // (H_v^T H_v)_SS + w_s I, lower triangle: H^T H less the invalid rows' share.
  Eigen::Ref<Eigen::MatrixXd> a = support_matrix_.topLeftCorner(n, n);
  // The support rows increase, so these are in H^T H's lower triangle.
  const Eigen::MatrixXd& hth = inverse_->hth();
  for (int c = 0; c < n; ++c) {
    for (int r = c; r < n; ++r) a(r, c) = hth(support_rows_[r], support_rows_[c]);
  }
  if (!invalid_rows_.empty()) {
    // H_R,S^T (k, q) = H (R_q, S_k).
    const int r = static_cast<int>(invalid_rows_.size());
    const Eigen::MatrixXd& h = inverse_->h();
    Eigen::Map<Eigen::MatrixXd> h_rs = GrowOnlyMatrix(&support_invalid_storage_, n, r);
    for (int q = 0; q < r; ++q) {
      for (int k = 0; k < n; ++k) h_rs(k, q) = h(invalid_rows_[q], support_rows_[k]);
    }
    a.selfadjointView<Eigen::Lower>().rankUpdate(h_rs, -1.0);
  }
  a.diagonal().array() += options_.support_weight;
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> factor(a);
  return factor.info() == Eigen::Success;
}

void ForceReconstructor::Reconstruct(const Eigen::VectorXd& d_mm,
                                     const std::vector<bool>& valid,
                                     ForceFrame* frame) {
  TAC3D_DEMAND(frame != nullptr);
  const int m = num_markers_;
  if (d_mm.size() != 3 * m) {
    throw Error(fmt::format("ForceReconstructor: D has {} entries, expected 3N = {}", d_mm.size(),
                            3 * m));
  }
  if (!valid.empty() && static_cast<int>(valid.size()) != m) {
    throw Error(fmt::format("ForceReconstructor: {} validity flags for {} markers", valid.size(), m));
  }
  frame->forces_n.resize(3 * m);
  invalid_.clear();
  for (int i = 0; i < m; ++i) {
    const bool ok = (valid.empty() || valid[i]) && std::isfinite(d_mm(i)) &&
                    std::isfinite(d_mm(m + i)) && std::isfinite(d_mm(2 * m + i));
    if (!ok) invalid_.push_back(i);
    for (int axis = 0; axis < 3; ++axis) {
      d_valid_(axis * m + i) = ok ? d_mm(axis * m + i) : 0.0;
      d_work_(axis * m + i) = static_cast<float>(d_valid_(axis * m + i));
    }
  }
  invalid_rows_.clear();
  for (int axis = 0; axis < 3; ++axis) {
    for (int i : invalid_) invalid_rows_.push_back(axis * m + i);
  }
  frame->num_invalid_markers = static_cast<int>(invalid_.size());
  frame->status = ForceStatus::kOk;
  frame->num_support_markers = 0;
  frame->support_refined = false;
  frame->resultant_force_n.setZero();
  frame->resultant_moment_nmm.setZero();
  if (frame->num_invalid_markers == m) {
    frame->forces_n.setZero();
    frame->status = ForceStatus::kNoValidMarkers;
    return;
  }

  // Lost markers: their rows of the data become the model's prediction z, (I - M_RR) z = M_R D0.
  if (!invalid_.empty()) {
    if (invalid_ != cached_invalid_) FactorRestrictedProblem();
    if (restricted_ok_) {
      const int r = static_cast<int>(invalid_rows_.size());
      Eigen::Ref<Eigen::VectorXd> z = z_work_.head(r);
      const Eigen::MatrixXd& influence = inverse_->influence();
      for (int k = 0; k < r; ++k) z(k) = influence.col(invalid_rows_[k]).dot(d_valid_);
      const Eigen::Map<const Eigen::MatrixXd> l(restricted_storage_.data(), r, r);
      l.triangularView<Eigen::Lower>().solveInPlace(z);
      l.triangularView<Eigen::Lower>().adjoint().solveInPlace(z);
      for (int k = 0; k < r; ++k) d_work_(invalid_rows_[k]) = static_cast<float>(z(k));
    } else {
      frame->status = ForceStatus::kRestrictedProblemIllConditioned;
    }
  }

  // The support needs only the normal forces: K's z rows are a third of the GEMV, which is
  // memory-bound (K is 5.8 MB); the rest is computed only if the re-solve does not replace it.
  if (options_.support_refinement && frame->status == ForceStatus::kOk) {
    f_work_.tail(m).noalias() = inverse_->k().bottomRows(m) * d_work_;
    frame->forces_n.tail(m) = f_work_.tail(m).cast<double>();
    frame->support_refined = RefineOnSupport(frame);
  }
  if (!frame->support_refined) {
    f_work_.noalias() = inverse_->k() * d_work_;
    frame->forces_n = f_work_.cast<double>();
  }

  for (int axis = 0; axis < 3; ++axis) frame->forces_n.segment(axis * m, m) *= options_.gains(axis);
  size_t next_invalid = 0;
  for (int i = 0; i < m; ++i) {
    const bool is_invalid = next_invalid < invalid_.size() && invalid_[next_invalid] == i;
    if (is_invalid) ++next_invalid;
    Eigen::Vector3d p = marker_positions_[i];
    if (!is_invalid) p += Eigen::Vector3d(d_mm(i), d_mm(m + i), d_mm(2 * m + i));
    const Eigen::Vector3d f = frame->MarkerForce(i);
    frame->resultant_force_n += f;
    frame->resultant_moment_nmm += p.cross(f);
  }
}

ForceFrame ForceReconstructor::Reconstruct(const Eigen::VectorXd& d_mm,
                                           const std::vector<bool>& valid) {
  ForceFrame frame;
  Reconstruct(d_mm, valid, &frame);
  return frame;
}

ForceUncertainty ForceReconstructor::CalcUncertainty(
    const Eigen::Vector3d& noise_variance_mm2) const {
  for (int axis = 0; axis < 3; ++axis) {
    if (!(noise_variance_mm2(axis) >= 0.0 && std::isfinite(noise_variance_mm2(axis)))) {
      throw Error(fmt::format("ForceReconstructor::CalcUncertainty: the {} noise variance must be "
                              ">= 0 and finite, got {}",
                              "xyz"[axis], noise_variance_mm2(axis)));
    }
  }
  const int m = num_markers_;
  // S is diagonal: diag(K S K^T)_j = sum_i K_ji^2 S_ii.
  Eigen::VectorXd s(3 * m);
  for (int axis = 0; axis < 3; ++axis) s.segment(axis * m, m).setConstant(noise_variance_mm2(axis));
  const Eigen::MatrixXd& k = inverse_->k_double();
  const Eigen::VectorXd variance = k.cwiseAbs2() * s;
  ForceUncertainty uncertainty;
  uncertainty.marker_sigma_n.resize(3, m);
  for (int axis = 0; axis < 3; ++axis) {
    uncertainty.marker_sigma_n.row(axis) =
        options_.gains(axis) * variance.segment(axis * m, m).cwiseSqrt().transpose();
    // The resultant component is a^T D with a the sum of K's rows of that axis.
    const Eigen::VectorXd a = k.middleRows(axis * m, m).colwise().sum().transpose();
    uncertainty.resultant_sigma_n(axis) =
        options_.gains(axis) * std::sqrt(a.cwiseAbs2().dot(s));
  }
  return uncertainty;
}

}  // namespace tac3d
