#pragma once

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d::testing {

/// The built-in sensor (DefaultSensorConfig()), made once per test program.
inline const SensorConfig& DefaultSensor() {
  static const SensorConfig config = DefaultSensorConfig();
  return config;
}

/// The prototype shrunk to 3 x 3 markers on a 12 mm dome, 3 mm thick (python/tests/conftest.py
/// has the same): its compliance model and twin body build in about a second.
inline SensorConfig SmallSensor() {
  SensorConfig sensor = DefaultSensorConfig();
  sensor.markers.rows = sensor.markers.cols = 3;
  sensor.elastic_body.base_diameter_mm = 12.0;
  sensor.elastic_body.thickness_mm = 3.0;
  sensor.elastic_body.outer_radius_mm = 20.0;
  return sensor;
}

}  // namespace tac3d::testing
