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

/// One header a CSV may start with, and the number of fields its rows have.
struct NumberCsvLayout {
  std::string header;
  std::size_t num_fields = 0;
};

/// ParseNumberCsv for a file that may start with any of `layouts`' headers; the rows have the
/// matched layout's field count.
/// @param layout_index set to the index of the matched layout (may be null).
std::vector<std::vector<double>> ParseNumberCsv(const std::string& csv_text,
                                                const std::string& source,
                                                const std::vector<NumberCsvLayout>& layouts,
                                                std::size_t* layout_index);

}  // namespace tac3d
