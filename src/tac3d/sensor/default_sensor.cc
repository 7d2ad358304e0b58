#include "tac3d/sensor/default_sensor.h"

#include <Eigen/Geometry>

namespace tac3d {
namespace {

Rigid3 Pose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Rigid3 pose = Rigid3::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

}  // namespace

SensorConfig DefaultSensorConfig() {
  // The prototype's camera, light path, markers, body and glass are SensorConfig's defaults;
  // the design leaves them as they are and adds the mirrors and virtual cameras below.
  SensorConfig config;
  // The output of DesignLightPath(DesignOptionsOf(SensorConfig{}), SensorConfig{}), as
  // `tac3d design --out sensor.yaml` writes it with the defaults (GCC 12, -O3
  // -march=x86-64-v3): shortest round-trip decimals, so these are its doubles bit for bit,
  // signed zeros included. design/light_path_design_test checks the solver against them.
  config.mirrors = {
      {"mirror_1",
       Rectangle3{{-24.809519684686403, 0.0, -21.39096522159323},
                  {0.3265285125918584, 0.0, -0.9451873520443175},
                  {0.0, 1.0, 0.0},
                  9.216019824004427,
                  13.863388143086441}},
      {"mirror_2",
       Rectangle3{{-4.363202310378334, 0.0, -24.559860324489108},
                  {-0.7237853184721175, 0.0, 0.6900252261796054},
                  {0.0, 1.0, 0.0},
                  6.028310051368385,
                  7.3498334829463925}},
      {"mirror_3",
       Rectangle3{{4.363202310378334, 0.0, -24.559860324489108},
                  {0.7237853184721175, 0.0, 0.6900252261796054},
                  {-0.0, -1.0, -0.0},
                  6.028310051368385,
                  7.3498334829463925}},
      {"mirror_4",
       Rectangle3{{24.809519684686403, 0.0, -21.39096522159323},
                  {-0.3265285125918584, 0.0, -0.9451873520443175},
                  {-0.0, -1.0, -0.0},
                  9.216019824004427,
                  13.863388143086441}},
  };
  const CameraIntrinsics& cam = config.camera.intrinsics;
  config.virtual_cameras = {
      {"vcam_left",
       ImageHalf::kLeft,
       Pose(Eigen::Matrix3d{{0.5790054542633966, 0.0, 0.8153236682037618},
                            {0.0, 1.0, 0.0},
                            {-0.8153236682037618, 0.0, 0.5790054542633964}},
            {-49.00218604474618, 0.0, -49.00218604474621}),
       cam,
       0,
       320},
      {"vcam_right",
       ImageHalf::kRight,
       Pose(Eigen::Matrix3d{{0.5790054542633966, 0.0, -0.8153236682037618},
                            {0.0, 1.0, 0.0},
                            {0.8153236682037618, 0.0, 0.5790054542633964}},
            {49.00218604474618, 0.0, -49.00218604474621}),
       cam,
       320,
       640},
  };
  return config;
}

SensorConfig LoadSensorOrDefault(const std::string& path) {
  return path.empty() ? DefaultSensorConfig() : LoadSensorConfig(path);
}

}  // namespace tac3d
