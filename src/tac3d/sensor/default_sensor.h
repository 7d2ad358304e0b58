#pragma once

#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// The built-in sensor: the paper's prototype (SensorConfig's defaults) with the mirrors and
/// virtual cameras the light-path design gives it (`tac3d design` with the defaults). The
/// designed values are stored, not solved for at run time, so that what only needs a sensor
/// does not link the design solver; design/light_path_design_test checks that the solver
/// still gives them.
SensorConfig DefaultSensorConfig();

/// The sensor a command or a run works on: the YAML file `path` (LoadSensorConfig) if one is
/// given, else DefaultSensorConfig(). @throws Error as LoadSensorConfig does.
SensorConfig LoadSensorOrDefault(const std::string& path);

}  // namespace tac3d
