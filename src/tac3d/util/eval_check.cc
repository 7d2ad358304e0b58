#include "tac3d/util/eval_check.h"

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/json_number.h"

namespace tac3d {
namespace {

EvalCheck Make(std::string name, double value, double tolerance, std::string unit,
               EvalCheck::Bound bound) {
  EvalCheck check{std::move(name), value, tolerance, std::move(unit), bound};
  check.pass = std::isfinite(value) &&
               (bound == EvalCheck::Bound::kAtMost ? value <= tolerance : value >= tolerance);
  return check;
}

}  // namespace

EvalCheck EvalCheck::AtMost(std::string name, double value, double tolerance, std::string unit) {
  return Make(std::move(name), value, tolerance, std::move(unit), Bound::kAtMost);
}

EvalCheck EvalCheck::AtLeast(std::string name, double value, double tolerance, std::string unit) {
  return Make(std::move(name), value, tolerance, std::move(unit), Bound::kAtLeast);
}

EvalCheck EvalCheck::NotApplicable(std::string name, double tolerance, Bound bound, std::string unit) {
  EvalCheck check{std::move(name), std::numeric_limits<double>::quiet_NaN(), tolerance,
                  std::move(unit), bound};
  check.applicable = false;
  check.pass = true;
  return check;
}

std::string EvalCheck::Format() const {
  const std::string shown =
      applicable ? fmt::format("{:.4g}{}{}", value, unit.empty() ? "" : " ", unit) : "n/a";
  return fmt::format("{:<4} {:<36} {} ({} {:.4g}{}{})", pass ? "ok" : "FAIL", name, shown,
                     bound == Bound::kAtMost ? "<=" : ">=", tolerance, unit.empty() ? "" : " ",
                     unit);
}

nlohmann::json ToJson(const EvalCheck& check) {
  return {{"name", check.name},
          {"value", FiniteOrNull(check.value)},
          {"tolerance", check.tolerance},
          {"unit", check.unit},
          {"bound", check.bound == EvalCheck::Bound::kAtMost ? "max" : "min"},
          {"applicable", check.applicable},
          {"pass", check.pass}};
}

nlohmann::json ToJson(const std::vector<EvalCheck>& checks) {
  nlohmann::json json = nlohmann::json::array();
  for (const EvalCheck& check : checks) json.push_back(ToJson(check));
  return json;
}

EvalCheck EvalCheckFromJson(const nlohmann::json& json) {
  try {
    EvalCheck check;
    check.name = json.at("name").get<std::string>();
    const nlohmann::json& value = json.at("value");
    check.value = value.is_null() ? std::numeric_limits<double>::quiet_NaN() : value.get<double>();
    check.tolerance = json.at("tolerance").get<double>();
    check.unit = json.value("unit", "");
    check.bound = json.value("bound", "max") == "min" ? EvalCheck::Bound::kAtLeast
                                                      : EvalCheck::Bound::kAtMost;
    check.applicable = json.value("applicable", true);
    check.pass = json.at("pass").get<bool>();
    return check;
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("an evaluation check in JSON: {}", e.what()));
  }
}

std::string FormatChecks(const std::vector<EvalCheck>& checks) {
  std::string text;
  for (const EvalCheck& check : checks) text += check.Format() + "\n";
  return text;
}

bool AllPass(const std::vector<EvalCheck>& checks) {
  if (checks.empty()) return false;
  for (const EvalCheck& check : checks) {
    if (!check.pass) return false;
  }
  return true;
}

}  // namespace tac3d
