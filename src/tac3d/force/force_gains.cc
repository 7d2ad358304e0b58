#include "tac3d/force/force_gains.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Malformed lines listed in one error message, at most.
constexpr int kMaxListedErrors = 10;

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  return s.substr(begin, s.find_last_not_of(" \t\r") - begin + 1);
}

// The line's numbers (num_fields of them), or what is wrong with it.
std::string ParseNumberLine(const std::string& line,
                            size_t num_fields,
                            std::vector<double>* values) {
  std::vector<std::string> fields;
  std::stringstream stream(line);
  for (std::string field; std::getline(stream, field, ',');) fields.push_back(Trim(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  if (fields.size() != num_fields) {
    return fmt::format("expected {} fields, got {}", num_fields, fields.size());
  }
  values->resize(num_fields);
  for (size_t k = 0; k < num_fields; ++k) {
    const std::string& field = fields[k];
    const auto [end, error] =
        std::from_chars(field.data(), field.data() + field.size(), (*values)[k]);
    if (field.empty() || error != std::errc() || end != field.data() + field.size() ||
        !std::isfinite((*values)[k])) {
      return fmt::format("field {} '{}' is not a finite number", k + 1, field);
    }
  }
  return "";
}

// The rows of a CSV of finite numbers under a fixed header: blank and '#' lines skipped,
// every malformed line reported in one error as "source:line: what".
std::vector<std::vector<double>> ParseNumberRows(const std::string& csv_text,
                                                 const std::string& source,
                                                 const std::string& expected_header,
                                                 size_t num_fields) {
  std::stringstream stream(csv_text);
  std::vector<std::vector<double>> rows;
  std::vector<std::string> errors;
  bool have_header = false;
  int line_number = 0;
  for (std::string raw; std::getline(stream, raw);) {
    ++line_number;
    const std::string line = Trim(raw);
    if (line.empty() || line.front() == '#') continue;
    if (!have_header) {
      std::string header;
      for (char c : line) {
        if (c != ' ' && c != '\t') header += c;
      }
      if (header != expected_header) {
        throw Error(fmt::format("{}:{}: expected the header '{}', got '{}'",
                                source,
                                line_number,
                                expected_header,
                                line));
      }
      have_header = true;
      continue;
    }
    std::vector<double> values;
    const std::string error = ParseNumberLine(line, num_fields, &values);
    if (error.empty()) {
      rows.push_back(std::move(values));
    } else {
      errors.push_back(fmt::format("{}:{}: {}", source, line_number, error));
    }
  }
  if (!have_header) throw Error(fmt::format("{}: no header line '{}'", source, expected_header));
  if (!errors.empty()) {
    std::string message = fmt::format("{}: {} malformed line(s):", source, errors.size());
    for (int k = 0; k < std::min<int>(kMaxListedErrors, errors.size()); ++k) {
      message += "\n  " + errors[k];
    }
    if (errors.size() > kMaxListedErrors) message += "\n  ...";
    throw Error(message);
  }
  if (rows.empty()) throw Error(fmt::format("{}: no rows after the header", source));
  return rows;
}

std::string ReadWholeFile(const std::string& path, const char* what) {
  std::ifstream file(path);
  if (!file) throw Error(fmt::format("cannot read {} from {}", what, path));
  std::stringstream buffer;
  buffer << file.rdbuf();
  return buffer.str();
}

}  // namespace

std::vector<ForcePair> ParseForcePairs(const std::string& csv_text, const std::string& source) {
  std::vector<ForcePair> pairs;
  for (const std::vector<double>& row : ParseNumberRows(csv_text, source, kForcePairCsvHeader, 6)) {
    pairs.push_back(
        {Eigen::Vector3d(row[0], row[1], row[2]), Eigen::Vector3d(row[3], row[4], row[5])});
  }
  return pairs;
}

std::vector<ForcePair> LoadForcePairs(const std::string& path) {
  return ParseForcePairs(ReadWholeFile(path, "force pairs"), path);
}

std::vector<CalibrationPress> ParseCalibrationPresses(const std::string& csv_text,
                                                      int num_markers,
                                                      const std::string& source) {
  std::vector<CalibrationPress> presses;
  for (const std::vector<double>& row :
       ParseNumberRows(csv_text, source, kCalibrationPressCsvHeader, 3 + 3 * num_markers)) {
    presses.push_back({Eigen::Map<const Eigen::VectorXd>(row.data() + 3, 3 * num_markers),
                       Eigen::Vector3d(row[0], row[1], row[2])});
  }
  return presses;
}

std::vector<CalibrationPress> LoadCalibrationPresses(const std::string& path, int num_markers) {
  return ParseCalibrationPresses(ReadWholeFile(path, "calibration presses"), num_markers, path);
}

std::string CalibrationPressesToCsv(const std::vector<CalibrationPress>& presses) {
  std::string csv = std::string(kCalibrationPressCsvHeader) + "\n";
  for (const CalibrationPress& press : presses) {
    csv += fmt::format("{:.17g},{:.17g},{:.17g}",
                       press.reference_n.x(),
                       press.reference_n.y(),
                       press.reference_n.z());
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

nlohmann::json ToJson(const ForceGainFit& fit) {
  const auto vec = [](const Eigen::Vector3d& v) { return nlohmann::json{v.x(), v.y(), v.z()}; };
  return {{"gains", vec(fit.gains)},
          {"r_squared", vec(fit.r_squared)},
          {"residual_rms_n", vec(fit.residual_rms_n)},
          {"num_pairs", fit.num_pairs}};
}

ForceGainFit FitForceGains(const std::vector<ForcePair>& pairs) {
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
    if (!(mm > 0.0)) {
      throw Error(fmt::format("FitForceGains: every measured f{} is zero; the calibration must "
                              "load that axis",
                              "xyz"[axis]));
    }
    const double gain = mr / mm;
    if (!(gain > 0.0)) {
      throw Error(fmt::format("FitForceGains: the f{} gain is {} <= 0; measured and reference "
                              "forces disagree in sign (axes or frames swapped?)",
                              "xyz"[axis], gain));
    }
    double ss_res = 0.0, ss_tot = 0.0;
    for (const ForcePair& pair : pairs) {
      ss_res += std::pow(pair.reference_n(axis) - gain * pair.measured_n(axis), 2);
      ss_tot += std::pow(pair.reference_n(axis) - mean_ref, 2);
    }
    fit.gains(axis) = gain;
    fit.residual_rms_n(axis) = std::sqrt(ss_res / count);
    fit.r_squared(axis) = ss_tot > 0.0 ? 1.0 - ss_res / ss_tot : (ss_res == 0.0 ? 1.0 : 0.0);
  }
  return fit;
}

}  // namespace tac3d
