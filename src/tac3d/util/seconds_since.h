#pragma once

#include <chrono>

namespace tac3d {

/// Seconds of the steady clock since `start`: the timing every summary reports.
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace tac3d
