#pragma once

#include <cstdint>
#include <string>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

/// A plausible, deterministic frame for tests, benchmarks and sensor-less demos: markers on
/// the default dome (pitch 1.27 mm, sphere radius 45 mm), a dent that moves with `index`,
/// forces along the displacements, the sphere's normals, every value distinct (a small
/// index- and marker-dependent offset), marker index % n lost, contact where |f| > 1e-3 N, and
/// the resultants summed from the markers (moment about the origin, N mm). timestamp_s is
/// index / 90 (a 90 fps camera).
TactileFrame MakeSyntheticTactileFrame(const std::string& sn,
                                       std::int64_t index,
                                       int rows = 20,
                                       int cols = 20);

}  // namespace tac3d
