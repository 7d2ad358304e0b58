#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace tac3d {

/// One figure of an evaluation against its acceptance bound: the record every evaluation
/// (`tac3d eval ...`) reports its checks in, and prints one way.
struct EvalCheck {
  enum class Bound { kAtMost, kAtLeast };

  std::string name;
  double value = 0.0;
  double tolerance = 0.0;
  std::string unit;
  Bound bound = Bound::kAtMost;
  /// False when the figure does not exist for this input (a scene without a material
  /// boundary has no boundary error): it then passes, and prints as "n/a".
  bool applicable = true;
  /// value is finite and within the bound, or the check is not applicable.
  bool pass = false;

  /// value <= tolerance.
  static EvalCheck AtMost(std::string name, double value, double tolerance, std::string unit = "");
  /// value >= tolerance.
  static EvalCheck AtLeast(std::string name, double value, double tolerance, std::string unit = "");
  /// A check that does not apply to this input (passes; value NaN).
  static EvalCheck NotApplicable(std::string name, double tolerance, Bound bound, std::string unit = "");

  /// "ok   name  value unit (<= tolerance)", "FAIL ..." or "ok   name  n/a ...".
  std::string Format() const;
};

/// {"name", "value" (null when not finite), "tolerance", "unit", "bound": "max"|"min",
///  "applicable", "pass"}.
nlohmann::json ToJson(const EvalCheck& check);
nlohmann::json ToJson(const std::vector<EvalCheck>& checks);
/// The inverse of ToJson (a missing unit, bound or applicable takes its default).
/// @throws tac3d::Error naming the missing field.
EvalCheck EvalCheckFromJson(const nlohmann::json& json);

/// Every check's Format(), a line each: the head of every evaluation's report.
std::string FormatChecks(const std::vector<EvalCheck>& checks);

/// True when every check passes (and there is at least one).
bool AllPass(const std::vector<EvalCheck>& checks);

}  // namespace tac3d
