#pragma once

#include <algorithm>
#include <limits>
#include <vector>

namespace tac3d {

/// The q-quantile (q in [0, 1]) of `values` by the nearest rank (the sorted value at
/// round(q (n - 1))); NaN when there are none.
inline double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5))];
}

}  // namespace tac3d
