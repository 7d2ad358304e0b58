#include <algorithm>
#include <cctype>
#include <cstdio>
#include <optional>

#include <unistd.h>

#include <fmt/format.h>

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "tac3d/runtime/sensor_stream.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"

namespace tac3d::cli {

bool ShowProgress(bool json) { return !json || isatty(STDERR_FILENO) != 0; }

void PrintChecks(const nlohmann::json& checks) {
  for (const nlohmann::json& check : checks) {
    std::printf("%s\n", EvalCheckFromJson(check).Format().c_str());
  }
}

void AddDriftOption(CLI::App* cmd, DriftMode* mode, const std::string& help) {
  // Not CLI11's CheckedTransformer: its description and messages print the modes' values, an
  // uint8_t, as characters.
  const auto to_mode = [](std::string& value) -> std::string {
    std::string name = value;
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
    const std::optional<DriftMode> parsed = runtime::ParseDriftMode(name);
    if (!parsed) return fmt::format("'{}' is not off, flag or rezero", value);
    value = std::to_string(static_cast<int>(*parsed));
    return "";
  };
  cmd->add_option("--drift", *mode, help)->transform(CLI::Validator(to_mode, "{off, flag, rezero}"));
}

void RefuseOptions(const CLI::App& cmd,
                   std::initializer_list<const char*> names,
                   const std::string& why) {
  for (const char* name : names) {
    if (cmd.count(name) > 0) throw Error(fmt::format("{} {}", name, why));
  }
}

void ValidateNamingFlags(const std::function<void()>& validate,
                         std::initializer_list<std::pair<std::string_view, std::string_view>> flags) {
  try {
    validate();
  } catch (const Error& e) {
    const std::string_view message = e.what();
    for (const auto& [field, flag] : flags) {
      if (message.substr(0, field.size()) == field) {
        throw Error(fmt::format("{}{}", flag, message.substr(field.size())));
      }
    }
    throw;
  }
}

}  // namespace tac3d::cli
