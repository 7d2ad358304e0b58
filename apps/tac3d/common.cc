#include <filesystem>

#include <fmt/format.h>

#include "commands.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {

SensorConfig LoadSensorOrDefault(const std::string& path) {
  return path.empty() ? DefaultSensorConfig() : LoadSensorConfig(path);
}

void MakeDirectory(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) throw Error(fmt::format("cannot create directory '{}': {}", path, ec.message()));
}

}  // namespace tac3d::cli
