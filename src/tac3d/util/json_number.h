#pragma once

#include <cmath>

#include <nlohmann/json.hpp>

namespace tac3d {

/// A figure for JSON, which has no NaN or infinity: the number, or null where it is not finite
/// (a figure that could not be measured).
inline nlohmann::json FiniteOrNull(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

}  // namespace tac3d
