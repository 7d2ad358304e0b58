#include <cstdio>
#include <cstdlib>
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

std::string DefaultCacheDir() {
  if (const char* dir = std::getenv("TAC3D_CACHE_DIR"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/tac3d";
  if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/tac3d";
  return ".tac3d-cache";
}

void PrintChecks(const nlohmann::json& checks) {
  for (const nlohmann::json& check : checks) {
    std::printf("%s\n", EvalCheckFromJson(check).Format().c_str());
  }
}

void MakeDirectory(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) throw Error(fmt::format("cannot create directory '{}': {}", path, ec.message()));
}

}  // namespace tac3d::cli
