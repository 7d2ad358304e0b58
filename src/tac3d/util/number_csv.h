#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace tac3d {

/// Parses a CSV of finite numbers under a fixed header line: `expected_header` (compared with
/// spaces and tabs removed), then rows of exactly `num_fields` comma-separated numbers. Blank
/// lines and lines starting with '#' are skipped; spaces around fields are allowed.
/// @param source names the text in error messages (a file name).
/// @throws tac3d::Error listing every malformed line as "source:line: what" (a wrong field
///   count, a field that is not a finite number; at most 10 listed), a missing or different
///   header, or no rows.
std::vector<std::vector<double>> ParseNumberCsv(const std::string& csv_text,
                                                const std::string& source,
                                                const std::string& expected_header,
                                                std::size_t num_fields);

}  // namespace tac3d
