#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace tac3d {

/// Parses a CSV of finite numbers under a fixed header line: `expected_header` (compared with
/// spaces and tabs removed), then rows of exactly `num_fields` comma-separated numbers. Blank
/// lines and lines starting with '#' are skipped; spaces around fields are allowed.
/// @param source names the text in error messages (a file name).
/// @param max_abs the largest magnitude a field may have (a physical bound, so that sums of
///   squares of the values stay finite).
/// @throws tac3d::Error listing every malformed line as "source:line: what" (a wrong field
///   count, a field that is not a finite number or beyond +-max_abs; at most 10 listed), a
///   missing or different header, or no rows. Lines and fields are quoted shortened.
std::vector<std::vector<double>> ParseNumberCsv(
    const std::string& csv_text,
    const std::string& source,
    const std::string& expected_header,
    std::size_t num_fields,
    double max_abs = std::numeric_limits<double>::max());

/// One header a CSV may start with, the number of fields its rows have, and the largest
/// magnitude of a field.
struct NumberCsvLayout {
  std::string header;
  std::size_t num_fields = 0;
  double max_abs = std::numeric_limits<double>::max();
};

/// ParseNumberCsv for a file that may start with any of `layouts`' headers; the rows have the
/// matched layout's field count.
/// @param layout_index set to the index of the matched layout (may be null).
std::vector<std::vector<double>> ParseNumberCsv(const std::string& csv_text,
                                                const std::string& source,
                                                const std::vector<NumberCsvLayout>& layouts,
                                                std::size_t* layout_index);

}  // namespace tac3d
