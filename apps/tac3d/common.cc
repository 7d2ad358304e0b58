#include <cstdio>
#include <cstdlib>

#include <fmt/format.h>

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"

namespace tac3d::cli {

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

void RefuseOptions(const CLI::App& cmd,
                   std::initializer_list<const char*> names,
                   const std::string& why) {
  for (const char* name : names) {
    if (cmd.count(name) > 0) throw Error(fmt::format("{} {}", name, why));
  }
}

}  // namespace tac3d::cli
