#include "tac3d/slip/slip_estimator.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

void Require(bool ok, const char* field, const char* bound, double value) {
  if (!ok || !std::isfinite(value)) {
    throw Error(fmt::format("SlipOptions.{} = {} must be {}", field, value, bound));
  }
}

}  // namespace

void SlipOptions::Validate() const {
  Require(min_contact_markers >= 1, "min_contact_markers", ">= 1", min_contact_markers);
  Require(plateau_quantile > 0 && plateau_quantile <= 1,
          "plateau_quantile",
          "in (0, 1]",
          plateau_quantile);
  Require(plateau_tolerance >= 0 && plateau_tolerance < 1,
          "plateau_tolerance",
          "in [0, 1)",
          plateau_tolerance);
  Require(noise_sigmas >= 0, "noise_sigmas", ">= 0", noise_sigmas);
  Require(marker_force_sigma_n >= 0, "marker_force_sigma_n", ">= 0", marker_force_sigma_n);
  Require(displacement_sigma_mm >= 0, "displacement_sigma_mm", ">= 0", displacement_sigma_mm);
  Require(lag_tolerance >= 0, "lag_tolerance", ">= 0", lag_tolerance);
  Require(stick_below >= 0 && stick_below <= 1, "stick_below", "in [0, 1]", stick_below);
  Require(saturation_tolerance >= 0 && saturation_tolerance < 1,
          "saturation_tolerance",
          "in [0, 1)",
          saturation_tolerance);
  Require(safety_factor >= 1, "safety_factor", ">= 1", safety_factor);
  Require(cone_sigmas > 0, "cone_sigmas", "> 0", cone_sigmas);
}

SlipEstimator::SlipEstimator(int num_markers, const SlipOptions& options)
    : options_((options.Validate(), options)),
      num_markers_(num_markers),
      displacement_sigma_mm_(options.displacement_sigma_mm) {
  if (num_markers < 1)
    throw Error(fmt::format("SlipEstimator: {} markers, need >= 1", num_markers));
  const auto n = static_cast<std::size_t>(num_markers);
  sigma_n_.assign(n, options.marker_force_sigma_n);
  contact_index_.resize(n);
  ratio_.resize(n);
  ratio_sigma_.resize(n);
  sorted_.resize(n);
  normal_n_.resize(n);
  slipping_.assign(n, false);
  on_plateau_.assign(n, false);
  on_cone_.assign(n, false);
  in_contact_.assign(n, false);
  previous_mm_.assign(n, Eigen::Vector3d::Zero());
  previous_valid_.assign(n, false);
  for (auto& a : axis_) a.resize(n);
}

void SlipEstimator::SetMarkerForceSigma(const Eigen::Matrix3Xd& sigma_n) {
  if (sigma_n.cols() != num_markers_) {
    throw Error(
        fmt::format("SlipEstimator: {} force sigmas for {} markers", sigma_n.cols(), num_markers_));
  }
  if (!sigma_n.allFinite() || (sigma_n.array() < 0).any()) {
    throw Error("SlipEstimator: force sigmas must be finite and >= 0");
  }
  // The RMS over the axes: the ratio's noise is isotropic to first order.
  for (int i = 0; i < num_markers_; ++i) sigma_n_[i] = sigma_n.col(i).norm() / std::sqrt(3.0);
}

void SlipEstimator::SetDisplacementVariance(const Eigen::Vector3d& variance_mm2) {
  if (!variance_mm2.allFinite() || (variance_mm2.array() < 0).any()) {
    throw Error("SlipEstimator: displacement variances must be finite and >= 0");
  }
  displacement_sigma_mm_ = std::sqrt(variance_mm2.mean());
}

// Median of the first `count` entries of `v` (reordered).
double SlipEstimator::Median(std::vector<double>& v, int count) {
  const auto mid = v.begin() + count / 2;
  std::nth_element(v.begin(), mid, v.begin() + count);
  return *mid;
}

FrameSlip SlipEstimator::Estimate(const TactileFrame& frame) {
  if (frame.num_markers() != num_markers_ ||
      frame.forces_n.size() != static_cast<std::size_t>(num_markers_) ||
      frame.displacements_mm.size() != static_cast<std::size_t>(num_markers_)) {
    throw Error(fmt::format(
        "SlipEstimator: a frame of {} markers, built for {}", frame.num_markers(), num_markers_));
  }
  if (frame.has(FrameFlag::kInitializing) || frame.has(FrameFlag::kZeroed)) Reset();
  std::fill(slipping_.begin(), slipping_.end(), false);
  num_slipping_ = 0;
  rigid_increment_mm_.setZero();
  CollectRatios(frame);
  FrameSlip out;
  double ratio = 0.0;
  if (num_contact_ < options_.min_contact_markers) {
    out.state = SlipState::kNone;
    num_contact_ = 0;
    gross_seen_still_ = false;
    carried_since_stick_ = false;
    held_friction_ = held_friction_sigma_ = FrameSlip::kNaN;
  } else {
    FindPlateau();
    contact_normal_.setZero();
    for (int c = 0; c < num_contact_; ++c) {
      contact_normal_ += normal_n_[c] * frame.normals[contact_index_[c]];
    }
    if (contact_normal_.norm() > 0.0) contact_normal_.normalize();
    ApplyMotion(frame);
    const LoadRatio contact = CalcLoadRatio(frame, nullptr);
    ratio = contact.ratio;
    out.state = Classify(frame, ratio, contact.sigma());
    if (out.state == SlipState::kGrossSlip) {
      // The whole contact slips.
      for (int c = 0; c < num_contact_; ++c) slipping_[contact_index_[c]] = true;
      num_slipping_ = num_contact_;
      EstimateFriction(frame, contact, &out);
    } else if (out.state == SlipState::kPartialSlip) {
      EstimateFriction(frame, contact, &out);
    } else if (out.state == SlipState::kStick) {
      carried_since_stick_ = false;
      std::fill(slipping_.begin(), slipping_.end(), false);
      num_slipping_ = 0;
    }
    // Held for still frames: an estimate with motion evidence, not a gross slip read on a
    // contact never seen still (a noisy small load can look saturated).
    const bool evidence = out.state == SlipState::kPartialSlip ||
                          (out.state == SlipState::kGrossSlip && gross_seen_still_);
    held_friction_ = evidence ? out.friction : FrameSlip::kNaN;
    held_friction_sigma_ = evidence ? out.friction_sigma : FrameSlip::kNaN;
    out.fraction = static_cast<double>(num_slipping_) / num_contact_;
  }
  previous_ratio_ = ratio;
  for (int i = 0; i < num_markers_; ++i) {
    // Only a marker in contact in both frames has an increment that says stick or slip: one
    // coming into contact moves with the indentation.
    previous_valid_[i] =
        frame.valid[i] && frame.contact[i] && frame.displacements_mm[i].allFinite();
    if (previous_valid_[i]) previous_mm_[i] = frame.displacements_mm[i];
  }
  has_previous_ = true;
  return out;
}

void SlipEstimator::CollectRatios(const TactileFrame& frame) {
  num_contact_ = 0;
  std::fill(in_contact_.begin(), in_contact_.end(), false);
  for (int i = 0; i < num_markers_; ++i) {
    if (!frame.contact[i] || !frame.valid[i]) continue;
    const Eigen::Vector3d& f = frame.forces_n[i];
    const Eigen::Vector3d& n = frame.normals[i];
    const double fn = -f.dot(n);
    if (!(fn > 0.0) || !f.allFinite() || !n.allFinite()) continue;
    const double r = (f + fn * n).norm() / fn;
    contact_index_[num_contact_] = i;
    in_contact_[i] = true;
    normal_n_[num_contact_] = fn;
    ratio_[num_contact_] = r;
    // First-order noise of |F_t| / F_n under an isotropic force noise sigma.
    ratio_sigma_[num_contact_] = sigma_n_[i] * std::sqrt(1.0 + r * r) / fn;
    ++num_contact_;
  }
}

void SlipEstimator::FindPlateau() {
  const double k = options_.noise_sigmas;
  std::copy(ratio_.begin(), ratio_.begin() + num_contact_, sorted_.begin());
  const auto q = static_cast<int>(std::ceil(options_.plateau_quantile * num_contact_)) - 1;
  const int qi = std::clamp(q, 0, num_contact_ - 1);
  std::nth_element(sorted_.begin(), sorted_.begin() + qi, sorted_.begin() + num_contact_);
  const double floor = (1.0 - options_.plateau_tolerance) * sorted_[qi];
  for (int c = 0; c < num_contact_; ++c) {
    const double r = ratio_[c], s = ratio_sigma_[c];
    on_plateau_[c] = r > k * s && r >= floor - k * s;
  }
}

void SlipEstimator::ApplyMotion(const TactileFrame& frame) {
  const double k = options_.noise_sigmas;
  // The rigid motion: the median increment of the contact's off-plateau markers (stuck by
  // their traction), or of all its markers when too few are off it.
  int count = 0;
  for (const bool plateau_only : {false, true}) {
    count = 0;
    for (int c = 0; c < num_contact_; ++c) {
      const int i = contact_index_[c];
      if ((!plateau_only && on_plateau_[c]) || !has_previous_ || !previous_valid_[i]) continue;
      const Eigen::Vector3d du = frame.displacements_mm[i] - previous_mm_[i];
      for (int a = 0; a < 3; ++a) axis_[a][count] = du[a];
      ++count;
    }
    if (count >= options_.min_contact_markers) break;
  }
  const double step_noise_mm = std::sqrt(2.0) * displacement_sigma_mm_;
  moving_ = false;
  bool carried = false;
  if (count >= options_.min_contact_markers) {
    for (int a = 0; a < 3; ++a) rigid_increment_mm_[a] = Median(axis_[a], count);
    moving_ = rigid_increment_mm_.norm() > k * step_noise_mm;
    // Carried along by the object: the tangential part moved (the normal part is indentation,
    // which a changing grip force moves).
    const Eigen::Vector3d& n = contact_normal_;
    carried = (rigid_increment_mm_ - rigid_increment_mm_.dot(n) * n).norm() > k * step_noise_mm;
  }
  if (!moving_) rigid_increment_mm_.setZero();
  // Without a motion history the load may have come with the object's motion.
  if (count < options_.min_contact_markers || carried) carried_since_stick_ = true;
  const double lag_mm = k * step_noise_mm + options_.lag_tolerance * rigid_increment_mm_.norm();
  for (int c = 0; c < num_contact_; ++c) {
    const int i = contact_index_[c];
    bool slipping = on_plateau_[c];
    if (slipping && moving_ && previous_valid_[i]) {
      const Eigen::Vector3d du = frame.displacements_mm[i] - previous_mm_[i];
      slipping = (du - rigid_increment_mm_).norm() > lag_mm;
    }
    if (slipping) {
      slipping_[i] = true;
      ++num_slipping_;
    }
  }
}

SlipState SlipEstimator::Classify(const TactileFrame& frame, double ratio, double sigma) {
  const double tol = options_.saturation_tolerance;
  // The median marker ratio: on a saturated contact every marker sits at mu, so it equals R.
  std::copy(ratio_.begin(), ratio_.begin() + num_contact_, sorted_.begin());
  const double median = Median(sorted_, num_contact_);
  bool seen = false;
  const bool dragged = IsDragged(frame, &seen);
  if (gross_seen_still_ && ratio >= (1.0 - tol) * previous_ratio_) {
    return SlipState::kGrossSlip;  // the friction level holds: still sliding
  }
  gross_seen_still_ = false;
  if (!(ratio > options_.noise_sigmas * sigma)) return SlipState::kStick;  // no tangential load
  // Gross slip starts on a contact the object carried along before it came to rest (a stuck
  // contact under a load held or growing by the noise a frame looks saturated and still too),
  // and only with a marker inside the contact's rim (without one, the force inverse smooths a
  // stuck contact's edge-concentrated shear to uniform ratios).
  if (std::abs(ratio - median) <= tol * median && !dragged && carried_since_stick_ &&
      HasInteriorMarker(frame)) {
    gross_seen_still_ = seen;
    return SlipState::kGrossSlip;
  }
  // Below the median marker's ratio: a saturated annulus carries it while the stuck core sits
  // lower. Near it: a saturated contact still dragged by a stuck core.
  if (ratio <= (1.0 + tol) * median) return SlipState::kPartialSlip;
  // Shear concentrated at the edge (Mindlin's full stick, q0 / sqrt(1 - rho^2) over a Hertz
  // pressure, has R = 1.5 times the median ratio; a thin slip annulus, c/a > 0.8, too): the
  // markers tell, a thin annulus on the plateau that lags the contact's motion.
  const double fraction = static_cast<double>(num_slipping_) / num_contact_;
  return fraction < options_.stick_below ? SlipState::kStick : SlipState::kPartialSlip;
}

bool SlipEstimator::HasInteriorMarker(const TactileFrame& frame) const {
  const int rows = frame.rows, cols = frame.cols;
  for (int c = 0; c < num_contact_; ++c) {
    const int i = contact_index_[c], row = i / cols, col = i % cols;
    if (row > 0 && row < rows - 1 && col > 0 && col < cols - 1 && in_contact_[i - 1] &&
        in_contact_[i + 1] && in_contact_[i - cols] && in_contact_[i + cols]) {
      return true;
    }
  }
  return false;
}

bool SlipEstimator::IsDragged(const TactileFrame& frame, bool* seen) {
  const Eigen::Vector3d& normal = contact_normal_;
  // The tangential increment of each contact marker (the normal part is indentation).
  int count = 0;
  for (int c = 0; c < num_contact_; ++c) {
    const int i = contact_index_[c];
    if (!has_previous_ || !previous_valid_[i]) continue;
    const Eigen::Vector3d du = frame.displacements_mm[i] - previous_mm_[i];
    axis_[0][count++] = (du - du.dot(normal) * normal).norm();
  }
  *seen = count >= options_.min_contact_markers;
  if (!*seen) return false;
  // A stuck core moves with the object however small the core: the plateau_quantile of the
  // increments, not their median, which the lagging annulus sets once it is half the contact.
  const auto q = static_cast<int>(std::ceil(options_.plateau_quantile * count)) - 1;
  const auto mid = axis_[0].begin() + std::clamp(q, 0, count - 1);
  std::nth_element(axis_[0].begin(), mid, axis_[0].begin() + count);
  return *mid > options_.noise_sigmas * std::sqrt(2.0) * displacement_sigma_mm_;
}

SlipEstimator::LoadRatio SlipEstimator::CalcLoadRatio(const TactileFrame& frame,
                                                      const std::vector<bool>* selected) const {
  LoadRatio out;
  Eigen::Vector3d sum_ft = Eigen::Vector3d::Zero();
  double sum_fn = 0.0, sum_var = 0.0;
  for (int c = 0; c < num_contact_; ++c) {
    if (selected && !(*selected)[c]) continue;
    const int i = contact_index_[c];
    sum_ft += frame.forces_n[i] + normal_n_[c] * frame.normals[i];
    sum_fn += normal_n_[c];
    sum_var += sigma_n_[i] * sigma_n_[i];
    ++out.count;
  }
  if (out.count == 0) return out;
  out.tangential_n = sum_ft.norm();
  const double mu = out.tangential_n / sum_fn;
  // The force noise of the sums, propagated to the quotient.
  const double noise_var = sum_var * (1.0 + mu * mu) / (sum_fn * sum_fn);
  // The spread of the load-weighted per-marker ratios: the standard error of their mean,
  // sum w^2 * sum w (r - mu)^2 with weights w = F_n / sum F_n.
  double spread = 0.0, weight2 = 0.0;
  for (int c = 0; c < num_contact_; ++c) {
    if (selected && !(*selected)[c]) continue;
    const double w = normal_n_[c] / sum_fn;
    spread += w * (ratio_[c] - mu) * (ratio_[c] - mu);
    weight2 += w * w;
  }
  out.ratio = mu;
  out.noise_sigma = std::sqrt(noise_var);
  out.spread_sigma = std::sqrt(spread * weight2);
  return out;
}

bool SlipEstimator::EstimateConeFriction(const TactileFrame& frame,
                                         const LoadRatio& contact,
                                         double* mu,
                                         double* mu_sigma) {
  // The slipping annulus sits on the friction cone: the load-weighted ratio of the markers that
  // slip (on the plateau and lagging the contact's motion) is mu. A sigma-clipped mean over
  // them: a stuck marker that passed (a ratio a little below mu, just inside the stick
  // boundary) leaves, the annulus' noise is cut on both sides alike. A still contact's slipping
  // markers cannot be told from its stuck ones (no lag): none are taken.
  constexpr int kClippings = 3;  // a bound on the passes, so the cost per frame is too
  const auto slips = [&](int c) { return moving_ && slipping_[contact_index_[c]]; };
  for (int c = 0; c < num_contact_; ++c) on_cone_[c] = slips(c);
  LoadRatio annulus = CalcLoadRatio(frame, &on_cone_);
  for (int k = 0; k < kClippings && annulus.count >= options_.min_contact_markers; ++k) {
    int kept = 0;
    for (int c = 0; c < num_contact_; ++c) {
      on_cone_[c] = slips(c) &&
                    std::abs(ratio_[c] - annulus.ratio) <= options_.cone_sigmas * ratio_sigma_[c];
      kept += on_cone_[c];
    }
    if (kept < options_.min_contact_markers) break;
    annulus = CalcLoadRatio(frame, &on_cone_);
  }
  // Enough slipping markers, and a cone not below the whole contact's ratio R beyond its noise
  // (Coulomb bounds the load by mu P; below R the ratio is noise).
  if (annulus.count >= options_.min_contact_markers &&
      annulus.ratio + options_.cone_sigmas * annulus.sigma() >= contact.ratio) {
    *mu = std::max(annulus.ratio, contact.ratio);
    *mu_sigma = annulus.sigma();
    return true;
  }
  // No cone seen this frame: the last estimate holds while the contact stays in partial slip.
  if (std::isnan(held_friction_)) return false;
  *mu = std::max(held_friction_, contact.ratio);
  *mu_sigma = held_friction_sigma_;
  return true;
}

void SlipEstimator::EstimateFriction(const TactileFrame& frame,
                                     const LoadRatio& contact,
                                     FrameSlip* out) {
  double mu = contact.ratio, mu_sigma = contact.sigma();
  if (out->state == SlipState::kPartialSlip) {
    if (!EstimateConeFriction(frame, contact, &mu, &mu_sigma)) return;
  }
  if (!(mu > 0.0)) return;
  out->friction = mu;
  out->friction_sigma = mu_sigma;
  out->least_normal_force_n = options_.safety_factor * contact.tangential_n / mu;
  if (out->state == SlipState::kGrossSlip) {
    out->margin = 0.0;  // sliding: no margin left
    out->margin_sigma = 0.0;
    return;
  }
  // 1 - R / mu; R's own uncertainty is the force noise only (the ratios' spread is mu's, not
  // R's), and the two are taken independent, which overstates sigma (they share markers).
  const double load = contact.ratio / mu;
  out->margin = 1.0 - load;
  out->margin_sigma = std::hypot(contact.noise_sigma, load * mu_sigma) / mu;
}

}  // namespace tac3d
