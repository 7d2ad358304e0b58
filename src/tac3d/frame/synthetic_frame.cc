#include "tac3d/frame/synthetic_frame.h"

#include <Eigen/Geometry>
#include <cmath>

namespace tac3d {

TactileFrame MakeSyntheticTactileFrame(const std::string& sn,
                                       std::int64_t index,
                                       int rows,
                                       int cols) {
  constexpr double kPitchMm = 1.27;
  constexpr double kRadiusMm = 45.0;
  constexpr double kBaseHeightMm = 8.0;
  TactileFrame frame = TactileFrame::Sized(rows, cols);
  frame.sn = sn;
  frame.index = index;
  frame.timestamp_s = static_cast<double>(index) / 90.0;
  const Eigen::Vector2d dent_mm(3.0 * std::cos(0.05 * index), 3.0 * std::sin(0.05 * index));
  const Eigen::Vector3d centre(0.0, 0.0, kBaseHeightMm - kRadiusMm);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int i = r * cols + c;
      const double x = (c - 0.5 * (cols - 1)) * kPitchMm;
      const double y = (r - 0.5 * (rows - 1)) * kPitchMm;
      const double z = centre.z() + std::sqrt(kRadiusMm * kRadiusMm - x * x - y * y);
      const Eigen::Vector3d rest(x, y, z);
      const double weight = std::exp(-(Eigen::Vector2d(x, y) - dent_mm).squaredNorm() / 8.0);
      // Distinct in every marker and frame, so a swapped or shifted value shows in a test.
      const double offset = 1e-6 * (i + 1) + 1e-9 * static_cast<double>(index % 1000);
      frame.displacements_mm[i] =
          Eigen::Vector3d(0.05 * weight + offset, -0.03 * weight, -0.4 * weight - offset);
      frame.positions_mm[i] = rest + frame.displacements_mm[i];
      frame.forces_n[i] = 0.02 * frame.displacements_mm[i] / 0.4;
      frame.normals[i] = (rest - centre).normalized();
      frame.contact[i] = frame.forces_n[i].norm() > 1e-3;
      frame.resultant_force_n += frame.forces_n[i];
      frame.resultant_moment_nmm += frame.positions_mm[i].cross(frame.forces_n[i]);
    }
  }
  const auto lost = static_cast<std::size_t>(index % frame.num_markers());
  frame.valid[lost] = false;
  frame.set(FrameFlag::kMarkersLost);
  // Every slip state in turn, values distinct in every frame.
  frame.slip.state = static_cast<SlipState>(index % kNumSlipStates);
  if (frame.slip.state >= SlipState::kStick) {
    frame.slip.fraction = 0.01 * static_cast<double>(index % 100);
  }
  if (frame.slip.state >= SlipState::kPartialSlip) {
    frame.slip.friction = 0.4 + 1e-3 * static_cast<double>(index % 100);
    frame.slip.friction_sigma = 0.01 + 1e-5 * static_cast<double>(index % 100);
    frame.slip.margin = frame.slip.state == SlipState::kGrossSlip
                            ? 0.0
                            : 0.2 + 1e-3 * static_cast<double>(index % 100);
    frame.slip.margin_sigma = 0.02 + 1e-5 * static_cast<double>(index % 100);
    frame.slip.least_normal_force_n = 1.5 + 1e-3 * static_cast<double>(index % 100);
  }
  return frame;
}

}  // namespace tac3d
