#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace tac3d {

/// One calibration press: the sensor's resultant force (reconstructed with unit gains) and a
/// reference force sensor's reading of the same press, both in the sensor frame (N).
struct ForcePair {
  Eigen::Vector3d measured_n = Eigen::Vector3d::Zero();
  Eigen::Vector3d reference_n = Eigen::Vector3d::Zero();
};

/// The header line of a force-pair CSV file.
inline constexpr const char* kForcePairCsvHeader = "fx_meas,fy_meas,fz_meas,fx_ref,fy_ref,fz_ref";

/// Parses a force-pair CSV: the header line kForcePairCsvHeader, then one pair a line, six
/// comma-separated finite numbers (N) within +-1e4. Blank lines and lines starting with '#' are
/// skipped; spaces around fields are allowed.
/// @param source names the text in error messages (a file name).
/// @throws tac3d::Error listing every malformed line as "source:line: what" (a wrong field
///   count, a field that is not a finite number or beyond +-1e4), a missing or different
///   header, or no pairs.
std::vector<ForcePair> ParseForcePairs(const std::string& csv_text,
                                       const std::string& source = "<text>");

/// Reads a force-pair CSV file (ParseForcePairs).
/// @throws tac3d::Error if the file cannot be read or is malformed.
std::vector<ForcePair> LoadForcePairs(const std::string& path);

/// Writes pairs in the format ParseForcePairs reads (17 significant digits).
std::string ForcePairsToCsv(const std::vector<ForcePair>& pairs);

/// One force-calibration press as material calibration needs it: the marker displacements
/// (a ForcePair's resultant cannot be recomputed for another H) and the reference sensor's
/// reading.
struct CalibrationPress {
  /// D (3N, mm), paper ordering, every marker valid.
  Eigen::VectorXd displacement_mm;
  /// The reference force (N), sensor frame.
  Eigen::Vector3d reference_n = Eigen::Vector3d::Zero();
  /// Where the load was centred (x, y in the sensor frame, mm; the probe's axis), when known
  /// (the twin, or a rig that positions the probe): material calibration then fits it too.
  std::optional<Eigen::Vector2d> contact_center_mm;
};

/// The header line of a calibration-press CSV file: the reference force, then the 3N
/// displacements (dx^1..dx^N, dy^1..dy^N, dz^1..dz^N, mm) on the same line.
inline constexpr const char* kCalibrationPressCsvHeader = "fx_ref,fy_ref,fz_ref,displacements_mm";
/// The same with each press's contact centre (mm) between the force and the displacements.
inline constexpr const char* kCalibrationPressWithCenterCsvHeader =
    "fx_ref,fy_ref,fz_ref,cx_mm,cy_mm,displacements_mm";

/// Parses a calibration-press CSV: the header kCalibrationPressCsvHeader, then one press a
/// line, 3 + 3 num_markers finite numbers; or kCalibrationPressWithCenterCsvHeader and
/// 5 + 3 num_markers numbers a line, each within +-1e4 (N, mm). Blank and '#' lines skipped,
/// spaces allowed.
/// @throws tac3d::Error as ParseForcePairs (every malformed line as "source:line: what").
std::vector<CalibrationPress> ParseCalibrationPresses(const std::string& csv_text,
                                                      int num_markers,
                                                      const std::string& source = "<text>");

/// Reads a calibration-press CSV file (ParseCalibrationPresses).
std::vector<CalibrationPress> LoadCalibrationPresses(const std::string& path, int num_markers);

/// Writes presses in the format ParseCalibrationPresses reads (17 significant digits), with the
/// contact centres when every press has one.
/// @throws tac3d::Error if some presses have a centre and others not.
std::string CalibrationPressesToCsv(const std::vector<CalibrationPress>& presses);

/// The fewest pairs FitForceGains accepts: one gain an axis fitted on one or two pairs fits
/// them (almost) exactly whatever the sensor does, so its R^2 would mean nothing.
inline constexpr int kMinForcePairs = 3;

/// The least R^2 a gain is usable with, by default. Good fits give R^2 near 1: >= 0.9997 on
/// the twin's calibration (docs/force.md), 0.957 for the normal axis when the model's Poisson's
/// ratio is 0.05 off (what material calibration then fixes). A calibration without shear fits
/// the tangential gains to noise: R^2 -0.47 and -0.86 (the demo at 60 steps), -0.08 and -1.00.
inline constexpr double kDefaultMinGainRSquared = 0.9;

/// What FitForceGains does with an axis whose R^2 is under the floor.
enum class PoorGainFit {
  kRefuse,  ///< throw: the gains are the product (`tac3d calibrate-force`)
  kFlag,    ///< return them marked unusable (ForceGainFit::usable): an evaluation reports them
  /// fit the axes the pairs determine, leave the others at 1 and say why
  /// (ForceGainFit::left_at_one): pairs from recordings that load some axes only.
  kLeaveAtOne,
};

struct ForceGainFitOptions {
  /// Each axis' R^2 must reach this for its gain to be usable (<= 1).
  double min_r_squared = kDefaultMinGainRSquared;
  PoorGainFit on_poor_fit = PoorGainFit::kRefuse;

  /// @throws Error naming the field unless min_r_squared is <= 1 (and not NaN).
  void Validate() const;
};

/// The per-axis gains and how well they fit.
struct ForceGainFit {
  /// (Cx, Cy, Cz): reference ~ C * measured per axis (dimensionless).
  Eigen::Vector3d gains = Eigen::Vector3d::Ones();
  /// 1 - SS_res / SS_tot per axis, SS_tot about the reference's mean (so a fit no better than
  /// the mean scores <= 0, also for a line through the origin).
  Eigen::Vector3d r_squared = Eigen::Vector3d::Zero();
  /// sqrt(SS_res / pairs) per axis (N).
  Eigen::Vector3d residual_rms_n = Eigen::Vector3d::Zero();
  int num_pairs = 0;
  /// The floor the fit was judged against (ForceGainFitOptions::min_r_squared).
  double min_r_squared = kDefaultMinGainRSquared;
  /// PoorGainFit::kLeaveAtOne: why each axis left at gain 1 was not fitted ("" where it was).
  std::array<std::string, 3> left_at_one;

  /// Whether the axis' (0 x, 1 y, 2 z) gain can be used: its R^2 reaches min_r_squared, or it
  /// was left at 1 (PoorGainFit::kLeaveAtOne).
  bool usable(int axis) const { return r_squared(axis) >= min_r_squared || !left_at_one[axis].empty(); }
  /// Whether every axis' can.
  bool usable() const { return usable(0) && usable(1) && usable(2); }
  /// Why the gains are unusable, naming each axis under the floor with its R^2, and what to
  /// do; "" when usable.
  std::string PoorFitMessage() const;
};

/// gains, r_squared, residual_rms_n, num_pairs, min_r_squared, usable, "left_at_one" ({axis
/// name: why} of the axes left at 1) and, when unusable, "warning" (PoorFitMessage).
nlohmann::json ToJson(const ForceGainFit& fit);

/// Least squares through the origin per axis (paper section V.A):
/// C_a = sum(meas_a ref_a) / sum(meas_a^2).
/// @throws tac3d::Error if there are fewer than kMinForcePairs pairs, or the options are
///   invalid; unless PoorGainFit::kLeaveAtOne (which leaves such an axis at 1 instead), if an
///   axis' measured values are all zero (the calibration did not excite it) or its gain comes
///   out <= 0 (the axis' sign is wrong); with PoorGainFit::kRefuse, if an axis' R^2 is under
///   options.min_r_squared (the message is PoorFitMessage's).
ForceGainFit FitForceGains(const std::vector<ForcePair>& pairs,
                           const ForceGainFitOptions& options = {});

}  // namespace tac3d
