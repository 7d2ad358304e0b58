#include "tac3d/io/marker_csv.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

constexpr const char* kHeader = "x_mm,y_mm,z_mm";

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  const auto e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

}  // namespace

std::vector<Eigen::Vector3d> ReadMarkerPositionsCsv(const std::string& path) {
  std::istringstream in(ReadFileCapped(path, kMaxConfigFileBytes, "marker positions"));
  std::vector<Eigen::Vector3d> positions;
  std::string line;
  int line_number = 0;
  bool header_seen = false;
  while (std::getline(in, line)) {
    ++line_number;
    line = Trim(line);
    if (line.empty() || line[0] == '#') continue;
    if (!header_seen) {
      if (line != kHeader) {
        throw Error(fmt::format("{}:{}: expected the header '{}'", path, line_number, kHeader));
      }
      header_seen = true;
      continue;
    }
    Eigen::Vector3d p;
    const char* cursor = line.data();
    const char* end = line.data() + line.size();
    for (int k = 0; k < 3; ++k) {
      while (cursor < end && *cursor == ' ') ++cursor;
      const auto [next, ec] = std::from_chars(cursor, end, p(k));
      if (ec != std::errc() || !std::isfinite(p(k))) {
        throw Error(fmt::format("{}:{}: field {} is not a finite number", path, line_number, k + 1));
      }
      cursor = next;
      while (cursor < end && *cursor == ' ') ++cursor;
      if (k < 2) {
        if (cursor == end || *cursor != ',') {
          throw Error(fmt::format("{}:{}: expected 3 comma-separated numbers", path, line_number));
        }
        ++cursor;
      }
    }
    if (cursor != end) {
      throw Error(fmt::format("{}:{}: expected 3 comma-separated numbers", path, line_number));
    }
    if (positions.size() == kMaxMarkerCsvRows) {
      throw Error(fmt::format("{}:{}: more than {} marker positions (a sensor has at most 100 x 100)",
                              path, line_number, kMaxMarkerCsvRows));
    }
    positions.push_back(p);
  }
  if (!header_seen) throw Error(fmt::format("{}: empty, expected the header '{}'", path, kHeader));
  return positions;
}

void WriteMarkerPositionsCsv(const std::vector<Eigen::Vector3d>& positions,
                             const std::string& path) {
  std::string out = std::string(kHeader) + "\n";
  for (const auto& p : positions) out += fmt::format("{},{},{}\n", p.x(), p.y(), p.z());
  WriteTextFileAtomically(path, out);
}

}  // namespace tac3d
