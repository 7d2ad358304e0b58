#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

namespace tac3d {

/// The largest Tikhonov weight ForceReconstructor accepts, as a multiple of the mean
/// eigenvalue of H^T H: beyond it the forces are shrunk to nothing (`--weight 1e300` gave
/// exactly zero forces).
inline constexpr double kMaxWeightToMeanEigenvalue = 1e4;

/// The largest force gain: a gain corrects the FEM model's remaining error, near 1 once the
/// material is calibrated (docs/force.md); 1000 is far past any such error, while `--gains
/// 1e300` was accepted and made every force infinite.
inline constexpr double kMaxForceGain = 1e3;

struct ForceReconstructorOptions {
  /// The Tikhonov weight w of eq. (3) ((mm/N)^2), e.g. from SelectRegularizationWeight.
  double weight = 0.0;
  /// Per-axis gains (Cx, Cy, Cz) multiplying the force components (paper section V.A), e.g.
  /// from FitForceGains; dimensionless.
  Eigen::Vector3d gains = Eigen::Vector3d::Ones();
  /// Contact-support refinement (docs/force.md): after F = K D, the markers whose normal force
  /// -f_z exceeds `support_threshold_n`, with every marker within `support_margin_pitches`
  /// marker pitches of one, are the support S; the forces are re-solved on S alone,
  /// min ||H_S F_S - D||^2 + support_weight ||F_S||^2, and are zero outside it. Knowing where
  /// the load can be removes the null space of the whole-field problem (a nearly
  /// incompressible layer's uniform press hardly changes its volume), so the resultant keeps
  /// its scale and loses most of its noise. Off: the paper's F = K D alone.
  bool support_refinement = true;
  double support_threshold_n = 0.02;
  double support_margin_pitches = 1.0;
  /// w of the support problem ((mm/N)^2): it only guards against a nearly singular H_S.
  double support_weight = 1e-3;
  /// A support of more markers than this (a load over most of the sensor) keeps F = K D: the
  /// re-solve costs (3 |S|)^3 / 3 flops.
  int max_support_markers = 120;

  /// @throws tac3d::Error naming the field: weight > 0 and finite; every gain in
  ///   (0, kMaxForceGain];
  ///   support_threshold_n >= 0, support_margin_pitches >= 0, support_weight > 0,
  ///   max_support_markers >= 1.
  void Validate() const;
};

enum class ForceStatus {
  kOk,
  /// Every marker was invalid: the forces are zero, not an estimate.
  kNoValidMarkers,
  /// The problem restricted to the valid markers could not be factored (w far too small for
  /// the markers lost): the forces are K D with the invalid markers' displacements set to 0.
  kRestrictedProblemIllConditioned,
};

/// One frame's force distribution.
struct ForceFrame {
  /// The force on each marker's surface patch (N), gains applied, in the paper's ordering
  /// F = (fx^1..fx^N, fy^1..fy^N, fz^1..fz^N) (eq. 1). A force into the body has f . n < 0.
  Eigen::VectorXd forces_n;
  /// Sum of the marker forces (N).
  Eigen::Vector3d resultant_force_n = Eigen::Vector3d::Zero();
  /// Sum of p_i x f_i about the sensor origin (N mm), p_i the marker's deformed position
  /// (rest position + displacement; the rest position where the marker is invalid).
  Eigen::Vector3d resultant_moment_nmm = Eigen::Vector3d::Zero();
  /// Markers flagged invalid or with a non-finite displacement component.
  int num_invalid_markers = 0;
  ForceStatus status = ForceStatus::kOk;
  /// Markers of the contact support the forces were re-solved on (0: no load found, or the
  /// refinement is off or was skipped).
  int num_support_markers = 0;
  /// True if the forces are the support problem's solution, false if they are F = K D.
  bool support_refined = false;

  int num_markers() const { return static_cast<int>(forces_n.size() / 3); }
  /// (fx, fy, fz) of marker i (N).
  Eigen::Vector3d MarkerForce(int i) const;
};

/// The per-marker force noise from the displacement noise: sqrt(diag(K S K^T)) (K with gains).
struct ForceUncertainty {
  /// 1-sigma of (fx, fy, fz) of each marker (N), one column a marker.
  Eigen::Matrix3Xd marker_sigma_n;
  /// 1-sigma of the resultant force's components (N) (its full covariance, not a sum of
  /// independent terms: the marker forces are correlated).
  Eigen::Vector3d resultant_sigma_n = Eigen::Vector3d::Zero();
};

/// The matrices of the paper's inverse (section IV.A, eq. 3-4) that depend on H and w alone:
/// K = (H^T H + w I)^-1 H^T in double and single precision, the influence matrix M = H K, and
/// H^T H (~40 MB for 400 markers, besides H's 11.5 MB). Immutable, so one instance serves every
/// ForceReconstructor of the same H and w, on any thread (SharedTikhonovInverse).
class TikhonovInverse {
 public:
  using RowMajorMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  /// @param h the compliance H (square, mm/N), paper ordering; held, not copied.
  /// @param weight the Tikhonov weight w ((mm/N)^2).
  /// @throws tac3d::Error if h is null, empty or not square, has a non-finite entry, w is not
  ///   > 0 and finite or is more than kMaxWeightToMeanEigenvalue times H^T H's mean eigenvalue,
  ///   or H^T H + w I is not positive definite in double precision (w far too small).
  TikhonovInverse(std::shared_ptr<const Eigen::MatrixXd> h, double weight);

  const Eigen::MatrixXd& h() const { return *h_; }
  double weight() const { return weight_; }
  /// K (3N x 3N, N/mm), double precision: for the uncertainty.
  const Eigen::MatrixXd& k_double() const { return k_double_; }
  /// K, single precision, row-major: the per-frame GEMV's.
  const RowMajorMatrixXf& k() const { return k_; }
  /// M = H K (3N x 3N), symmetric: column j is row j, the model's prediction of D_j from all of
  /// D.
  const Eigen::MatrixXd& influence() const { return influence_; }
  /// H^T H, lower triangle only, for the contact-support re-solve.
  const Eigen::MatrixXd& hth() const { return hth_; }

 private:
  std::shared_ptr<const Eigen::MatrixXd> h_;
  double weight_;
  Eigen::MatrixXd k_double_;
  RowMajorMatrixXf k_;
  Eigen::MatrixXd influence_;
  Eigen::MatrixXd hth_;
};

/// The TikhonovInverse of this H object (shared, not compared by value) and w: the one alive in
/// the process if another holder has it (another sensor of the same model), else a new one
/// kept for the next callers while it lives. Thread-safe: callers asking for the same inverse
/// at once wait for one computation (SharedCache).
/// @throws tac3d::Error as TikhonovInverse's constructor.
std::shared_ptr<const TikhonovInverse> SharedTikhonovInverse(
    const std::shared_ptr<const Eigen::MatrixXd>& h, double weight);

/// The paper's inverse (section IV.A, eq. 3-4): K = (H^T H + w I)^-1 H^T computed once,
/// then F = K D per frame as one single-precision row-major GEMV that allocates nothing.
///
/// Invalid markers (flagged, or any displacement component NaN/inf) are handled exactly as the
/// Tikhonov problem restricted to the valid rows, min ||H_v F - D_v||^2 + w ||F||^2, without
/// refactoring: its solution is the full solution K D~ for data D~ whose invalid rows R hold the
/// model's own prediction H_R F. With D0 the data with its invalid rows zeroed and M = H K (the
/// influence matrix, symmetric, precomputed) that prediction z = D~_R solves
///   (I - M_RR) z = M_R D0,   F = K D~ = K (D0 + z on the rows R),
/// where I - M_RR = I - H_R (H^T H + w I)^-1 H_R^T is symmetric positive definite (w > 0). A new
/// validity mask costs a gather of M_RR and one Cholesky factorisation of 3r x 3r (r invalid
/// markers), cached for the next frames with the same mask; every frame costs r dot products
/// with rows of M and one GEMV. The forces of invalid markers are then the regularised estimate
/// from their neighbours, never NaN.
///
/// Not thread-safe (per-frame workspace): one instance per stream. Its matrices (K, M, H^T H:
/// TikhonovInverse) are shared with every other reconstructor of the same H object and weight.
class ForceReconstructor {
 public:
  /// @param h the compliance H (3N x 3N, mm/N), paper ordering, shared: reconstructors of the
  ///   same H object and weight share one TikhonovInverse (SharedTikhonovInverse).
  /// @param marker_positions_mm the N rest positions (mm, sensor frame), for the moment.
  /// @throws tac3d::Error if the options are invalid, h is null, not 3N x 3N or not finite, or
  ///   H^T H + w I is not positive definite in double precision (w far too small).
  ForceReconstructor(const std::shared_ptr<const Eigen::MatrixXd>& h,
                     std::vector<Eigen::Vector3d> marker_positions_mm,
                     const ForceReconstructorOptions& options);
  /// The same with a copy of h, shared with no other reconstructor.
  ForceReconstructor(const Eigen::MatrixXd& h,
                     std::vector<Eigen::Vector3d> marker_positions_mm,
                     const ForceReconstructorOptions& options);

  /// F = K D for one frame, into `frame` (resized on first use only).
  /// @param d_mm marker displacements D (3N, mm), paper ordering; non-finite entries mark
  ///   their marker invalid.
  /// @param valid one flag a marker (false = lost), or empty for all valid.
  /// @throws tac3d::Error if d_mm or valid has the wrong size.
  void Reconstruct(const Eigen::VectorXd& d_mm, const std::vector<bool>& valid, ForceFrame* frame);
  /// The same, returning a new frame (allocates).
  ForceFrame Reconstruct(const Eigen::VectorXd& d_mm, const std::vector<bool>& valid = {});

  /// The 1-sigma force noise of each marker and of the resultant, all markers valid.
  /// @param noise_variance_mm2 the displacement noise variance along x, y, z (mm^2), the
  ///   diagonal of S per axis (EstimateDisplacementNoise).
  /// @throws tac3d::Error if a variance is negative or not finite.
  ForceUncertainty CalcUncertainty(const Eigen::Vector3d& noise_variance_mm2) const;

  /// Replaces the gains (e.g. after FitForceGains on frames reconstructed with unit gains).
  /// @throws tac3d::Error if a gain is not in (0, kMaxForceGain].
  void set_gains(const Eigen::Vector3d& gains);

  int num_markers() const { return num_markers_; }
  double weight() const { return options_.weight; }
  const Eigen::Vector3d& gains() const { return options_.gains; }
  const std::vector<Eigen::Vector3d>& marker_positions() const { return marker_positions_; }
  /// K without gains (3N x 3N, N/mm), single precision, row-major.
  const TikhonovInverse::RowMajorMatrixXf& k() const { return inverse_->k(); }
  /// The matrices, shared with every reconstructor of the same H object and weight.
  const std::shared_ptr<const TikhonovInverse>& inverse() const { return inverse_; }

 private:
  // Factors I - M_RR for this frame's invalid markers into the restricted-problem cache.
  void FactorRestrictedProblem();
  // Re-solves frame->forces_n (no gains yet) on the contact support; returns false (forces
  // untouched) if the support is empty, too large, or its problem cannot be factored. The
  // support problem's factor is cached while the support and the lost markers stay the same.
  bool RefineOnSupport(ForceFrame* frame);
  // Factors (H_v^T H_v)_SS + w_s I in place in support_matrix_; false if it is not positive
  // definite.
  bool FactorSupportProblem();

  int num_markers_;
  std::vector<Eigen::Vector3d> marker_positions_;
  ForceReconstructorOptions options_;
  std::shared_ptr<const TikhonovInverse> inverse_;

  // Per-frame workspace and the cache of the last validity mask. The matrices whose size
  // follows the number of invalid markers live in grow-only storage: a frame allocates only when
  // it has more invalid markers than every frame before.
  Eigen::VectorXf d_work_;
  Eigen::VectorXf f_work_;
  std::vector<int> invalid_;         // this frame's invalid markers, increasing
  std::vector<int> invalid_rows_;    // their 3r rows of D, axis-major
  std::vector<int> cached_invalid_;  // the markers the factor below was built for
  Eigen::VectorXd restricted_storage_;  // the Cholesky factor L of I - M_RR (3r x 3r, lower)
  bool restricted_ok_ = false;          // whether that factorisation succeeded
  Eigen::VectorXd z_work_;              // 3N

  // For the contact-support refinement: each marker's neighbours within the support margin, and
  // the workspace of the support problem.
  std::vector<std::vector<int>> support_neighbours_;
  std::vector<char> in_support_;
  std::vector<int> support_;       // marker indices, increasing
  std::vector<int> support_rows_;  // F indices of the support, 3 |S|
  Eigen::MatrixXd support_matrix_;  // the factor L of the support problem, lower
  std::vector<int> factored_support_;          // the support and the lost markers L was built
  std::vector<int> factored_support_invalid_;  // for, and whether its factorisation succeeded
  bool support_factor_ok_ = false;
  Eigen::VectorXd support_rhs_;
  Eigen::VectorXd support_invalid_storage_;  // H_R,S^T (3|S| x 3r), grow-only
  Eigen::VectorXd d_valid_;
};

}  // namespace tac3d
