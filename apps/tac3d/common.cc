#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"

namespace tac3d::cli {

SensorConfig LoadSensorOrDefault(const std::string& path) {
  return path.empty() ? DefaultSensorConfig() : LoadSensorConfig(path);
}

void PrintChecks(const nlohmann::json& checks) {
  for (const nlohmann::json& check : checks) {
    std::printf("%s\n", EvalCheckFromJson(check).Format().c_str());
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

void MakeDirectory(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) throw Error(fmt::format("cannot create directory '{}': {}", path, ec.message()));
}

}  // namespace tac3d::cli
