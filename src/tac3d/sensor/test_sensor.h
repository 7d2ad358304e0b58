#pragma once

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d::testing {

/// The built-in sensor (DefaultSensorConfig()), made once per test program.
inline const SensorConfig& DefaultSensor() {
  static const SensorConfig config = DefaultSensorConfig();
  return config;
}

}  // namespace tac3d::testing
