#include "tac3d/util/number_csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
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

// The first characters of `text`, with "..." when cut: a message quotes a line, not a file.
std::string Excerpt(const std::string& text) {
  constexpr size_t kMaxChars = 60;
  return text.size() <= kMaxChars ? text : text.substr(0, kMaxChars) + "...";
}

// The line's numbers (num_fields of them), or what is wrong with it.
std::string ParseNumberLine(const std::string& line,
                            size_t num_fields,
                            double max_abs,
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
      return fmt::format("field {} '{}' is not a finite number", k + 1, Excerpt(field));
    }
    if (std::abs((*values)[k]) > max_abs) {
      return fmt::format("field {} '{}' is beyond +-{}", k + 1, Excerpt(field), max_abs);
    }
  }
  return "";
}

}  // namespace

std::vector<std::vector<double>> ParseNumberCsv(const std::string& csv_text,
                                                const std::string& source,
                                                const std::string& expected_header,
                                                std::size_t num_fields,
                                                double max_abs) {
  return ParseNumberCsv(csv_text, source, {{expected_header, num_fields, max_abs}}, nullptr);
}

std::vector<std::vector<double>> ParseNumberCsv(const std::string& csv_text,
                                                const std::string& source,
                                                const std::vector<NumberCsvLayout>& layouts,
                                                std::size_t* layout_index) {
  TAC3D_DEMAND(!layouts.empty());
  std::string expected = "'" + layouts[0].header + "'";
  for (size_t k = 1; k < layouts.size(); ++k) expected += " or '" + layouts[k].header + "'";
  const NumberCsvLayout* layout = nullptr;
  std::stringstream stream(csv_text);
  std::vector<std::vector<double>> rows;
  std::vector<std::string> errors;
  int line_number = 0;
  for (std::string raw; std::getline(stream, raw);) {
    ++line_number;
    const std::string line = Trim(raw);
    if (line.empty() || line.front() == '#') continue;
    if (layout == nullptr) {
      std::string header;
      for (char c : line) {
        if (c != ' ' && c != '\t') header += c;
      }
      const auto match = std::find_if(layouts.begin(), layouts.end(),
                                      [&](const NumberCsvLayout& l) { return l.header == header; });
      if (match == layouts.end()) {
        throw Error(
            fmt::format("{}:{}: expected the header {}, got '{}'", source, line_number, expected,
                        Excerpt(line)));
      }
      layout = &*match;
      if (layout_index != nullptr) *layout_index = static_cast<std::size_t>(match - layouts.begin());
      continue;
    }
    std::vector<double> values;
    const std::string error = ParseNumberLine(line, layout->num_fields, layout->max_abs, &values);
    if (error.empty()) {
      rows.push_back(std::move(values));
    } else {
      errors.push_back(fmt::format("{}:{}: {}", source, line_number, error));
    }
  }
  if (layout == nullptr) throw Error(fmt::format("{}: no header line {}", source, expected));
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

}  // namespace tac3d
