#include <cmath>
#include <iterator>

#include <fmt/format.h>

#include "tac3d/web/web_server.h"

namespace tac3d {
namespace {

using Buffer = fmt::memory_buffer;

void Number(Buffer& out, double x, int decimals) {
  if (!std::isfinite(x)) {
    fmt::format_to(std::back_inserter(out), "null");
    return;
  }
  // "-0.000" carries nothing "0.000" does not; drop the sign of values that round to 0.
  if (std::abs(x) < 0.5 * std::pow(10.0, -decimals)) x = 0.0;
  fmt::format_to(std::back_inserter(out), "{:.{}f}", x, decimals);
}

void Vector(Buffer& out, const Eigen::Vector3d& v, int decimals) {
  out.push_back('[');
  for (int k = 0; k < 3; ++k) {
    if (k > 0) out.push_back(',');
    Number(out, v[k], decimals);
  }
  out.push_back(']');
}

// A flat [x0,y0,z0,x1,...] array; an invalid marker's values are null.
void Markers(Buffer& out,
             const char* key,
             const std::vector<Eigen::Vector3d>& values,
             const std::vector<bool>& valid,
             int decimals) {
  fmt::format_to(std::back_inserter(out), ",\"{}\":[", key);
  for (size_t i = 0; i < values.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (i > 0 || k > 0) out.push_back(',');
      if (i < valid.size() && !valid[i]) {
        fmt::format_to(std::back_inserter(out), "null");
      } else {
        Number(out, values[i][k], decimals);
      }
    }
  }
  out.push_back(']');
}

void Bits(Buffer& out, const char* key, const std::vector<bool>& bits) {
  fmt::format_to(std::back_inserter(out), ",\"{}\":\"", key);
  for (const bool b : bits) out.push_back(b ? '1' : '0');
  out.push_back('"');
}

// Characters that need no escaping in a JSON string; anything else in an SN is replaced.
std::string SafeString(const std::string& s) {
  std::string safe = s;
  for (char& c : safe) {
    const bool plain = (c >= 0x20 && c < 0x7f && c != '"' && c != '\\');
    if (!plain) c = '?';
  }
  return safe;
}

}  // namespace

std::string FrameToJson(const TactileFrame& f, double fps) {
  Buffer out;
  fmt::format_to(std::back_inserter(out),
                 "{{\"type\":\"frame\",\"sn\":\"{}\",\"index\":{},\"t\":",
                 SafeString(f.sn), f.index);
  Number(out, f.timestamp_s, 4);
  fmt::format_to(std::back_inserter(out), ",\"rows\":{},\"cols\":{}", f.rows, f.cols);
  Markers(out, "p", f.positions_mm, f.valid, 3);
  Markers(out, "d", f.displacements_mm, f.valid, 4);
  Markers(out, "f", f.forces_n, f.valid, 4);
  Markers(out, "n", f.normals, f.valid, 3);
  Bits(out, "valid", f.valid);
  Bits(out, "contact", f.contact);
  fmt::format_to(std::back_inserter(out), ",\"F\":");
  Vector(out, f.resultant_force_n, 4);
  fmt::format_to(std::back_inserter(out), ",\"M\":");
  Vector(out, f.resultant_moment_nmm, 3);
  fmt::format_to(std::back_inserter(out), ",\"flags\":\"{}\",\"init\":{},\"slip\":\"{}\"",
                 FrameFlagNames(f.flags), f.initialize_progress, SlipStateName(f.slip.state));
  const std::pair<const char*, double> slip_numbers[] = {
      {"slip_fraction", f.slip.fraction},
      {"mu", f.slip.friction},
      {"mu_sigma", f.slip.friction_sigma},
      {"slip_margin", f.slip.margin},
      {"slip_margin_sigma", f.slip.margin_sigma},
      {"least_normal_force_n", f.slip.least_normal_force_n}};
  for (const auto& [key, value] : slip_numbers) {
    fmt::format_to(std::back_inserter(out), ",\"{}\":", key);
    Number(out, value, 3);
  }
  fmt::format_to(std::back_inserter(out), ",\"fps\":");
  Number(out, fps, 1);
  out.push_back('}');
  return fmt::to_string(out);
}

}  // namespace tac3d
