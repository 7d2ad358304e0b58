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

// The line's six numbers, or what is wrong with it.
std::string ParsePairLine(const std::string& line, ForcePair* pair) {
  std::vector<std::string> fields;
  std::stringstream stream(line);
  for (std::string field; std::getline(stream, field, ',');) fields.push_back(Trim(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  if (fields.size() != 6) return fmt::format("expected 6 fields, got {}", fields.size());
  for (int k = 0; k < 6; ++k) {
    double value = 0.0;
    const std::string& field = fields[k];
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
    if (field.empty() || error != std::errc() || end != field.data() + field.size() ||
        !std::isfinite(value)) {
      return fmt::format("field {} '{}' is not a finite number", k + 1, field);
    }
    (k < 3 ? pair->measured_n : pair->reference_n)(k % 3) = value;
  }
  return "";
}

}  // namespace

std::vector<ForcePair> ParseForcePairs(const std::string& csv_text, const std::string& source) {
  std::stringstream stream(csv_text);
  std::vector<ForcePair> pairs;
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
      if (header != kForcePairCsvHeader) {
        throw Error(fmt::format("{}:{}: expected the header '{}', got '{}'", source, line_number,
                                kForcePairCsvHeader, line));
      }
      have_header = true;
      continue;
    }
    ForcePair pair;
    const std::string error = ParsePairLine(line, &pair);
    if (error.empty()) {
      pairs.push_back(pair);
    } else {
      errors.push_back(fmt::format("{}:{}: {}", source, line_number, error));
    }
  }
  if (!have_header) {
    throw Error(fmt::format("{}: no header line '{}'", source, kForcePairCsvHeader));
  }
  if (!errors.empty()) {
    std::string message = fmt::format("{}: {} malformed line(s):", source, errors.size());
    for (int k = 0; k < std::min<int>(kMaxListedErrors, errors.size()); ++k) {
      message += "\n  " + errors[k];
    }
    if (errors.size() > kMaxListedErrors) message += "\n  ...";
    throw Error(message);
  }
  if (pairs.empty()) throw Error(fmt::format("{}: no force pairs after the header", source));
  return pairs;
}

std::vector<ForcePair> LoadForcePairs(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw Error(fmt::format("cannot read force pairs from {}", path));
  std::stringstream buffer;
  buffer << file.rdbuf();
  return ParseForcePairs(buffer.str(), path);
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
