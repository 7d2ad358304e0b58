#include "tac3d/frame/tactile_frame.h"

#include <fmt/format.h>

#include <cmath>
#include <cstring>

#include "tac3d/util/error.h"

namespace tac3d {

const char* FrameFlagName(FrameFlag flag) {
  switch (flag) {
    case FrameFlag::kMarkersLost:
      return "markers_lost";
    case FrameFlag::kGridReacquired:
      return "grid_reacquired";
    case FrameFlag::kDisplacementOutOfRange:
      return "displacement_out_of_range";
    case FrameFlag::kForceOutOfRange:
      return "force_out_of_range";
    case FrameFlag::kInitializing:
      return "initializing";
    case FrameFlag::kZeroed:
      return "zeroed";
    case FrameFlag::kLightingChanged:
      return "lighting_changed";
    case FrameFlag::kDriftAtRest:
      return "drift_at_rest";
  }
  TAC3D_DEMAND(false);
}

const char* SlipStateName(SlipState state) {
  switch (state) {
    case SlipState::kUnknown:
      return "unknown";
    case SlipState::kNone:
      return "none";
    case SlipState::kStick:
      return "stick";
    case SlipState::kPartialSlip:
      return "partial_slip";
    case SlipState::kGrossSlip:
      return "gross_slip";
  }
  return "invalid";
}

bool FrameSlip::operator==(const FrameSlip& other) const {
  const auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; };
  return state == other.state && same(fraction, other.fraction) &&
         same(friction, other.friction) && same(friction_sigma, other.friction_sigma) &&
         same(margin, other.margin) && same(margin_sigma, other.margin_sigma) &&
         same(least_normal_force_n, other.least_normal_force_n);
}

std::string FrameFlagNames(std::uint32_t flags) {
  std::string names;
  for (const FrameFlag flag : kAllFrameFlags) {
    if ((flags & static_cast<std::uint32_t>(flag)) == 0) continue;
    if (!names.empty()) names += ' ';
    names += FrameFlagName(flag);
  }
  return names;
}

TactileFrame TactileFrame::Sized(int rows, int cols) {
  if (rows < 1 || cols < 1 || rows > kMaxGridSide || cols > kMaxGridSide) {
    throw Error(fmt::format("TactileFrame: grid {} x {} must be within 1 x 1 .. {} x {}", rows,
                            cols, kMaxGridSide, kMaxGridSide));
  }
  TactileFrame frame;
  frame.rows = rows;
  frame.cols = cols;
  const std::size_t n = static_cast<std::size_t>(rows) * cols;
  for (auto* v : {&frame.positions_mm, &frame.displacements_mm, &frame.forces_n, &frame.normals}) {
    v->assign(n, Eigen::Vector3d::Zero());
  }
  frame.valid.assign(n, true);
  frame.contact.assign(n, false);
  return frame;
}

void TactileFrame::set(FrameFlag flag, bool on) {
  const auto bit = static_cast<std::uint32_t>(flag);
  flags = on ? (flags | bit) : (flags & ~bit);
}

void TactileFrame::Validate() const {
  if (rows < 1 || cols < 1 || rows > kMaxGridSide || cols > kMaxGridSide) {
    throw Error(fmt::format("TactileFrame {}: grid {} x {} must be within 1 x 1 .. {} x {}", index,
                            rows, cols, kMaxGridSide, kMaxGridSide));
  }
  const std::size_t n = static_cast<std::size_t>(rows) * cols;
  auto check = [&](const char* name, std::size_t size) {
    if (size != n) {
      throw Error(fmt::format("TactileFrame {}: {} has {} entries, the {} x {} grid needs {}",
                              index,
                              name,
                              size,
                              rows,
                              cols,
                              n));
    }
  };
  check("positions_mm", positions_mm.size());
  check("displacements_mm", displacements_mm.size());
  check("forces_n", forces_n.size());
  check("normals", normals.size());
  check("valid", valid.size());
  check("contact", contact.size());
  if (initialize_progress < 0 || initialize_progress > 100) {
    throw Error(fmt::format(
        "TactileFrame {}: initialize_progress {} is outside 0..100", index, initialize_progress));
  }
  if (!std::isfinite(timestamp_s)) {
    throw Error(fmt::format("TactileFrame {}: timestamp_s {} is not finite", index, timestamp_s));
  }
  std::uint32_t known = 0;
  for (const FrameFlag flag : kAllFrameFlags) known |= static_cast<std::uint32_t>(flag);
  if ((flags & ~known) != 0) {
    throw Error(fmt::format(
        "TactileFrame {}: flags 0x{:x} has unknown bits 0x{:x}", index, flags, flags & ~known));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (valid[i] && !(positions_mm[i].allFinite() && displacements_mm[i].allFinite() &&
                      forces_n[i].allFinite())) {
      throw Error(fmt::format("TactileFrame {}: marker {} is valid but its position, displacement "
                              "or force is not finite",
                              index,
                              i));
    }
  }
  if (static_cast<int>(slip.state) >= kNumSlipStates) {
    throw Error(fmt::format(
        "TactileFrame {}: slip state {} is not a SlipState", index, static_cast<int>(slip.state)));
  }
}

}  // namespace tac3d
