#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

/// Thresholds of SlipEstimator (docs/slip.md says where each default comes from).
struct SlipOptions {
  /// Fewer contact markers than this is no contact (state kNone): a ratio statistic and a
  /// fraction need a contact patch, not one marker over the threshold.
  int min_contact_markers = 4;
  /// The contact's friction plateau is this quantile of its markers' traction ratios: a
  /// robust maximum that ignores the top (1 - q) of the markers, where edge noise lives. The
  /// contact is dragged when this quantile of its markers' tangential increments is above
  /// noise: at least the top (1 - q) moved, however small the stuck core.
  double plateau_quantile = 0.9;
  /// A marker is on the plateau when its ratio is at least (1 - plateau_tolerance) times the
  /// plateau, less noise_sigmas of its own ratio noise. 0.1: a Coulomb-saturated patch has one
  /// ratio; the FEM inverse's smoothing spreads it by a few per cent (docs/slip.md).
  double plateau_tolerance = 0.1;
  /// Noise multiplier k: a ratio within k sigma of zero is no tangential load (stick), a ratio
  /// within k sigma of the plateau is on it. 3: a 0.3 % false call per marker under Gaussian noise.
  double noise_sigmas = 3.0;
  /// 1-sigma force noise of a marker along each axis (N), used until SetMarkerForceSigma gives
  /// the measured one (the pipeline does after each reference, from ForceReconstructor's
  /// uncertainty). 0.002 N: the twin's at 0.005 mm displacement noise and w = 0.05.
  double marker_force_sigma_n = 0.002;
  /// 1-sigma displacement noise of a marker along each axis (mm), used until
  /// SetDisplacementSigma gives the measured one (the pipeline's reference noise).
  double displacement_sigma_mm = 0.005;
  /// A stuck marker follows the contact's rigid motion between frames; one whose increment
  /// departs from it by more than noise_sigmas * sqrt(2) * sigma + lag_tolerance * |rigid
  /// increment| lags: it slips. 0.25: the spread of a stuck patch's increments on a curved
  /// indenter, where the surface is not parallel to the motion everywhere.
  double lag_tolerance = 0.25;
  /// The contact-level saturation test (docs/slip.md): a contact is saturated when its
  /// load-weighted mean ratio R = |sum F_t| / sum F_n is within saturation_tolerance (relative)
  /// of its median marker ratio; an established gross slip persists while R drops by less than
  /// saturation_tolerance (relative) a frame. 0.1: Cattaneo-Mindlin gives R / median = 1 -
  /// (c/a)^3 once the slip annulus covers half the contact, so a still contact within 0.1 has a
  /// stuck core of at most 0.46 a; on the twin's slides 0.2 gives nearly the same states, 0.05
  /// and 0.3 worse ones (docs/slip.md).
  double saturation_tolerance = 0.1;
  /// A loaded contact whose shear is concentrated at the edge (R above its median marker ratio
  /// by more than saturation_tolerance) is in partial slip when at least this fraction of its
  /// markers slip (on the plateau and lagging), else stick. 0.1: well beyond the noise's 0.3 %
  /// false calls per marker.
  double stick_below = 0.1;
  /// FrameSlip::least_normal_force_n holds the present tangential load |Q| at mu / safety_factor:
  /// safety_factor * |Q| / mu. 1.5: covers mu read 5 % high (the force reconstruction's bias on
  /// the twin) and a tangential load that grows by a quarter before the next frame's update,
  /// 1.05 * 1.25, with room for what the checks have not seen (docs/slip.md). >= 1.
  double safety_factor = 1.5;
  /// mu in partial slip is a sigma-clipped load-weighted mean over the slipping markers: a
  /// marker stays on the friction cone while its ratio is within cone_sigmas of its own noise
  /// of the estimate; and a cone more than cone_sigmas of its sigma below the contact's ratio R
  /// is no cone. 2: keeps 95 % of the annulus' markers (cut on both sides alike, so no bias)
  /// and drops a stuck marker that passed for slipping, whose ratio is a little below mu
  /// (docs/slip.md).
  double cone_sigmas = 2.0;

  /// @throws tac3d::Error naming the field and the broken bound.
  void Validate() const;
};

/// Per-frame slip state of the contact (docs/slip.md), decided at the contact level from its
/// load-weighted mean traction ratio R = |sum F_t| / sum F_n, its median marker ratio and its
/// frame-to-frame motion (Cattaneo-Mindlin, Coulomb's |q| <= mu p):
/// - stick: no tangential load above R's own uncertainty, or the shear concentrated at the edge
///   (R above the median ratio by more than saturation_tolerance) with fewer than stick_below
///   of the markers slipping (below);
/// - gross slip: the ratio field uniform (R within saturation_tolerance of the median ratio)
///   and the contact not dragged (the plateau_quantile of its markers' tangential increments
///   since the previous frame within noise: no stuck core moves with the object): the whole
///   contact sits on the friction limit while the object slides over it. It starts only on a
///   contact the object has carried along (its tangential rigid increment above noise in a
///   frame) since it last read stick, or one without a motion history yet, and that has a
///   marker inside its rim (on a contact whose every marker is at its edge the force inverse
///   smooths a stuck contact's edge-concentrated shear to the same uniform ratios). It persists
///   while R holds (drops less than saturation_tolerance a frame), once it has been seen still;
///   mu = R, with sigma from the force noise and the ratios' spread;
/// - partial slip otherwise: a tangential load with a saturated annulus (R below the median
///   ratio, or a thin annulus of markers on the plateau that lag), or a saturated contact still
///   dragged by a stuck core.
/// The slip fraction in partial slip is per marker: a marker slips when its ratio r_i =
/// |F_t,i| / F_n,i (normal and tangential parts along the measured normal, paper section IV.B)
/// is on the contact's plateau (the plateau_quantile of its ratios, within plateau_tolerance
/// and noise_sigmas of its ratio noise) and, when the contact moves, it lags the contact's
/// rigid motion; 1 in gross slip, 0 in stick.
/// Friction in partial slip (docs/slip.md, "Friction before it slips"): the slipping annulus of a
/// Cattaneo-Mindlin contact sits on the friction cone, so mu is the load-weighted ratio
/// |sum F_t| / sum F_n of the slipping markers (sigma-clipped, cone_sigmas), at least the
/// contact's R (Coulomb bounds the whole load by mu P); in a frame without that evidence (the
/// contact still, too few slipping markers) the last estimate holds while the contact stays in
/// partial slip. The margin to gross slip 1 - R / mu and the least normal force
/// safety_factor * |Q| / mu follow; in gross slip mu = R and the margin is 0.
/// Allocates only in the constructor; not thread-safe.
class SlipEstimator {
 public:
  /// @param num_markers markers a frame has (rows * cols).
  /// @throws tac3d::Error if the options are invalid or num_markers < 1.
  SlipEstimator(int num_markers, const SlipOptions& options = {});

  /// Uses the measured 1-sigma force noise of each marker (N, one column a marker, x y z).
  /// @throws tac3d::Error if the size is wrong or a sigma is negative or not finite.
  void SetMarkerForceSigma(const Eigen::Matrix3Xd& sigma_n);

  /// Uses the measured displacement noise (variance along x, y, z, mm^2).
  /// @throws tac3d::Error if a variance is negative or not finite.
  void SetDisplacementVariance(const Eigen::Vector3d& variance_mm2);

  /// Forgets the previous frame (after a new reference: increments across it are meaningless).
  void Reset() {
    has_previous_ = false;
    gross_seen_still_ = false;
    carried_since_stick_ = false;
    held_friction_ = held_friction_sigma_ = FrameSlip::kNaN;
  }

  /// The slip estimate of `frame` from its forces_n, normals, valid, contact and displacements
  /// (and the previous frame's displacements, kept). Frames flagged kInitializing or kZeroed
  /// restart the motion history.
  /// @throws tac3d::Error if the frame has a different number of markers.
  FrameSlip Estimate(const TactileFrame& frame);

  /// The contact's rigid motion since the previous frame (mm), zero when not seen.
  const Eigen::Vector3d& rigid_increment_mm() const { return rigid_increment_mm_; }
  /// Per marker, whether the last Estimate found it slipping (false outside the contact).
  const std::vector<bool>& slipping() const { return slipping_; }
  int num_contact() const { return num_contact_; }
  int num_slipping() const { return num_slipping_; }
  const SlipOptions& options() const { return options_; }

 private:
  // The phases of Estimate: each contact marker's ratio and its noise; which ratios are on the
  // plateau; the frame-to-frame motion that keeps a following marker stuck; mu in gross slip.
  void CollectRatios(const TactileFrame& frame);
  void FindPlateau();
  void ApplyMotion(const TactileFrame& frame);
  // R = |sum F_t| / sum F_n over the contact markers (or its plateau markers only), the sums and
  // R's 1-sigma parts: the force noise's and the standard error from the ratios' spread.
  struct LoadRatio {
    double ratio = 0.0;
    double noise_sigma = 0.0;
    double spread_sigma = 0.0;
    double tangential_n = 0.0;  // |sum F_t|
    int count = 0;
    double sigma() const { return std::hypot(noise_sigma, spread_sigma); }
  };
  // `selected`: by contact slot, nullptr for every contact marker.
  LoadRatio CalcLoadRatio(const TactileFrame& frame, const std::vector<bool>* selected) const;
  // mu, the margin and the least normal force of a contact in partial or gross slip.
  void EstimateFriction(const TactileFrame& frame, const LoadRatio& contact, FrameSlip* out);
  // mu and its sigma in partial slip from the slipping markers' ratios (false: none seen).
  bool EstimateConeFriction(const TactileFrame& frame,
                            const LoadRatio& contact,
                            double* mu,
                            double* mu_sigma);
  // Whether the plateau_quantile of the contact markers' tangential increments since the
  // previous frame is above noise (a stuck core moves); *seen is false when too few contact
  // markers have an increment.
  bool IsDragged(const TactileFrame& frame, bool* seen);
  // Whether a contact marker has its four grid neighbours in contact too.
  bool HasInteriorMarker(const TactileFrame& frame) const;
  SlipState Classify(const TactileFrame& frame, double ratio, double sigma);
  static double Median(std::vector<double>& v, int count);

  SlipOptions options_;
  int num_markers_;
  std::vector<double> sigma_n_;  // isotropic 1-sigma force noise of each marker (N)
  // Per-frame scratch, sized once.
  std::vector<int> contact_index_;
  std::vector<double> ratio_;
  std::vector<double> ratio_sigma_;
  std::vector<double> sorted_;
  std::vector<double> normal_n_;
  std::vector<bool> slipping_;
  std::vector<bool> on_plateau_;  // by contact slot
  std::vector<bool> on_cone_;     // by contact slot: the markers mu in partial slip comes from
  std::vector<bool> in_contact_;  // by marker: a contact marker this frame
  bool moving_ = false;           // the contact moved since the previous frame (ApplyMotion)
  Eigen::Vector3d contact_normal_ = Eigen::Vector3d::UnitZ();  // load-weighted mean normal
  // The object carried the contact along (its tangential rigid increment above noise), or the
  // contact had no motion history, since it last read stick: what a gross slip starts from.
  bool carried_since_stick_ = false;
  // The last mu (and sigma) estimated from a moving contact, held while it stays in partial
  // slip without moving (its slipping markers cannot be told from the stuck ones then).
  double held_friction_ = FrameSlip::kNaN;
  double held_friction_sigma_ = FrameSlip::kNaN;
  std::vector<Eigen::Vector3d> previous_mm_;
  std::vector<bool> previous_valid_;  // valid and in contact in the previous frame
  std::vector<double> axis_[3];
  bool has_previous_ = false;
  bool gross_seen_still_ = false;  // the last frame was gross slip, established while still
  double previous_ratio_ = 0.0;    // the last frame's R
  double displacement_sigma_mm_;
  Eigen::Vector3d rigid_increment_mm_ = Eigen::Vector3d::Zero();
  int num_contact_ = 0;
  int num_slipping_ = 0;
};

}  // namespace tac3d
