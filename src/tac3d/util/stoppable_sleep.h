#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "tac3d/util/seconds_since.h"

namespace tac3d {

/// Sleeps `seconds` in 10 ms slices, giving up as soon as `stop` is set, so a stop request
/// (Ctrl-C, a client's $Q) ends even a long gap between a paced source's frames promptly.
/// Counted in double seconds: a gap of centuries (a file's timestamps, 1e300 s) would overflow
/// the clock's integer nanoseconds. `stop` may be null.
/// @return true when the time has passed, false when stopped first.
inline bool SleepUnlessStopped(double seconds, const std::atomic<bool>* stop) {
  constexpr double kSliceS = 0.01;
  const auto start = std::chrono::steady_clock::now();
  for (double left_s = seconds; left_s > 0.0; left_s = seconds - SecondsSince(start)) {
    if (stop != nullptr && *stop) return false;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(left_s, kSliceS)));
  }
  return true;
}

}  // namespace tac3d
