#include "tac3d/force/force_gains.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/number_csv.h"

namespace tac3d {
namespace {

// A press line holds 3 + 1200 numbers (~30 kB): room for ~8000 presses, far more than any
// calibration, while a wrong file fails at once instead of filling memory.
constexpr std::size_t kMaxCalibrationCsvBytes = 256u << 20;
// The largest force (N) or displacement (mm) a calibration file may hold: far beyond a
// fingertip's, while the fits' sums of squares stay finite (1e300 made the gain NaN).
constexpr double kMaxCalibrationValue = 1e4;

}  // namespace

std::vector<ForcePair> ParseForcePairs(const std::string& csv_text, const std::string& source) {
  std::vector<ForcePair> pairs;
  for (const std::vector<double>& row : ParseNumberCsv(csv_text, source, kForcePairCsvHeader, 6, kMaxCalibrationValue)) {
    pairs.push_back(
        {Eigen::Vector3d(row[0], row[1], row[2]), Eigen::Vector3d(row[3], row[4], row[5])});
  }
  return pairs;
}

std::vector<ForcePair> LoadForcePairs(const std::string& path) {
  return ParseForcePairs(ReadFileCapped(path, kMaxCalibrationCsvBytes, "force pairs"), path);
}

std::vector<CalibrationPress> ParseCalibrationPresses(const std::string& csv_text,
                                                      int num_markers,
                                                      const std::string& source) {
  const size_t size = 3 * static_cast<size_t>(num_markers);
  size_t layout = 0;
  const std::vector<std::vector<double>> rows =
      ParseNumberCsv(csv_text, source,
                     {{kCalibrationPressCsvHeader, 3 + size, kMaxCalibrationValue},
                      {kCalibrationPressWithCenterCsvHeader, 5 + size, kMaxCalibrationValue}},
                     &layout);
  const bool with_center = layout == 1;
  std::vector<CalibrationPress> presses;
  for (const std::vector<double>& row : rows) {
    CalibrationPress& press = presses.emplace_back();
    press.reference_n = Eigen::Vector3d(row[0], row[1], row[2]);
    if (with_center) press.contact_center_mm = Eigen::Vector2d(row[3], row[4]);
    press.displacement_mm = Eigen::Map<const Eigen::VectorXd>(row.data() + (with_center ? 5 : 3),
                                                              static_cast<Eigen::Index>(size));
  }
  return presses;
}

std::vector<CalibrationPress> LoadCalibrationPresses(const std::string& path, int num_markers) {
  return ParseCalibrationPresses(ReadFileCapped(path, kMaxCalibrationCsvBytes, "calibration presses"), num_markers, path);
}

std::string CalibrationPressesToCsv(const std::vector<CalibrationPress>& presses) {
  const auto centers = std::count_if(presses.begin(), presses.end(), [](const CalibrationPress& p) {
    return p.contact_center_mm.has_value();
  });
  if (centers != 0 && centers != static_cast<std::ptrdiff_t>(presses.size())) {
    throw Error(fmt::format("CalibrationPressesToCsv: {} of {} presses have a contact centre; a "
                            "file holds them for every press or for none",
                            centers, presses.size()));
  }
  std::string csv = std::string(centers != 0 ? kCalibrationPressWithCenterCsvHeader
                                             : kCalibrationPressCsvHeader) +
                    "\n";
  for (const CalibrationPress& press : presses) {
    csv += fmt::format("{:.17g},{:.17g},{:.17g}",
                       press.reference_n.x(),
                       press.reference_n.y(),
                       press.reference_n.z());
    if (press.contact_center_mm) {
      csv += fmt::format(",{:.17g},{:.17g}", press.contact_center_mm->x(), press.contact_center_mm->y());
    }
    for (double d : press.displacement_mm) csv += fmt::format(",{:.17g}", d);
    csv += "\n";
  }
  return csv;
}

std::string ForcePairsToCsv(const std::vector<ForcePair>& pairs) {
  std::string csv = std::string(kForcePairCsvHeader) + "\n";
  for (const ForcePair& pair : pairs) {
    csv += fmt::format("{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", pair.measured_n.x(),
                       pair.measured_n.y(), pair.measured_n.z(), pair.reference_n.x(),
                       pair.reference_n.y(), pair.reference_n.z());
  }
  return csv;
}

void ForceGainFitOptions::Validate() const {
  const OptionCheck require("force gain fit");
  require(min_r_squared <= 1.0, "min_r_squared", "<= 1 (R^2 never exceeds 1)", min_r_squared);
  require(on_poor_fit == PoorGainFit::kRefuse || on_poor_fit == PoorGainFit::kFlag ||
              on_poor_fit == PoorGainFit::kLeaveAtOne,
          "on_poor_fit", "refuse, flag or leave at one", static_cast<int>(on_poor_fit));
}

std::string ForceGainFit::PoorFitMessage() const {
  std::string axes;
  for (int axis = 0; axis < 3; ++axis) {
    if (usable(axis)) continue;
    axes += fmt::format("{}the f{} gain's R^2 is {:.3f}", axes.empty() ? "" : ", ", "xyz"[axis],
                        r_squared(axis));
  }
  if (axes.empty()) return "";
  return fmt::format(
      "{} (over {} pairs), under the floor {:g}: such a gain fits noise, not the sensor, and "
      "would scale every force on its axis wrongly. The calibration must load each axis well above "
      "its noise: add presses with shear (tangential force) in both x and y, and a range of "
      "normal forces (docs/force.md); a floor can be lowered (--min-r-squared) only for a fit "
      "known to be good",
      axes, num_pairs, min_r_squared);
}

nlohmann::json ToJson(const ForceGainFit& fit) {
  const auto vec = [](const Eigen::Vector3d& v) { return nlohmann::json{v.x(), v.y(), v.z()}; };
  nlohmann::json left = nlohmann::json::object();
  for (int axis = 0; axis < 3; ++axis) {
    if (!fit.left_at_one[axis].empty()) left[std::string(1, "xyz"[axis])] = fit.left_at_one[axis];
  }
  nlohmann::json j = {{"gains", vec(fit.gains)},
                      {"r_squared", vec(fit.r_squared)},
                      {"residual_rms_n", vec(fit.residual_rms_n)},
                      {"num_pairs", fit.num_pairs},
                      {"min_r_squared", fit.min_r_squared},
                      {"usable", fit.usable()},
                      {"left_at_one", left}};
  if (!fit.usable()) j["warning"] = fit.PoorFitMessage();
  return j;
}

ForceGainFit FitForceGains(const std::vector<ForcePair>& pairs, const ForceGainFitOptions& options) {
  options.Validate();
  if (static_cast<int>(pairs.size()) < kMinForcePairs) {
    throw Error(fmt::format("FitForceGains: {} force pair(s); the fit needs at least {} (with fewer, "
                            "R^2 says nothing about the gains)",
                            pairs.size(), kMinForcePairs));
  }
  ForceGainFit fit;
  fit.num_pairs = static_cast<int>(pairs.size());
  const double count = static_cast<double>(pairs.size());
  for (int axis = 0; axis < 3; ++axis) {
    double mm = 0.0, mr = 0.0, mean_ref = 0.0;
    for (const ForcePair& pair : pairs) {
      mm += pair.measured_n(axis) * pair.measured_n(axis);
      mr += pair.measured_n(axis) * pair.reference_n(axis);
      mean_ref += pair.reference_n(axis) / count;
    }
    const bool leave = options.on_poor_fit == PoorGainFit::kLeaveAtOne;
    if (!(mm > 0.0)) {
      const std::string why = fmt::format("every measured f{} is zero", "xyz"[axis]);
      if (!leave) throw Error(fmt::format("FitForceGains: {}; the calibration must load that axis", why));
      fit.left_at_one[axis] = why;
      continue;
    }
    const double gain = mr / mm;
    if (!(gain > 0.0)) {
      const std::string why = fmt::format("the f{} gain is {:.4g} <= 0", "xyz"[axis], gain);
      if (!leave) {
        throw Error(fmt::format("FitForceGains: {}; measured and reference forces disagree in sign (axes or frames "
                                "swapped?)",
                                why));
      }
      fit.left_at_one[axis] = why + ": measured and reference disagree in sign";
      continue;
    }
    double ss_res = 0.0, ss_tot = 0.0;
    for (const ForcePair& pair : pairs) {
      ss_res += std::pow(pair.reference_n(axis) - gain * pair.measured_n(axis), 2);
      ss_tot += std::pow(pair.reference_n(axis) - mean_ref, 2);
    }
    fit.gains(axis) = gain;
    fit.residual_rms_n(axis) = std::sqrt(ss_res / count);
    fit.r_squared(axis) = ss_tot > 0.0 ? 1.0 - ss_res / ss_tot : (ss_res == 0.0 ? 1.0 : 0.0);
    if (leave && fit.r_squared(axis) < options.min_r_squared) {
      fit.left_at_one[axis] = fmt::format("R^2 {:.4g} under {:g}: the pairs do not determine it (a fit {:.4g} would "
                                          "fit noise)",
                                          fit.r_squared(axis), options.min_r_squared, gain);
      fit.gains(axis) = 1.0;
    }
  }
  fit.min_r_squared = options.min_r_squared;
  if (options.on_poor_fit == PoorGainFit::kRefuse && !fit.usable()) {
    throw Error("FitForceGains: " + fit.PoorFitMessage());
  }
  return fit;
}

}  // namespace tac3d
