#pragma once

// Test-only helpers shared by the simulation module's tests (not part of the library, not
// installed): the small sensor's twin and a sphere scene on it.

#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "tac3d/scene/scene.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/simulation/twin_body.h"

namespace tac3d::testing {

/// The small sensor's twin body at E x youngs_modulus_factor (the nominal refinement and nu),
/// its contact grid 0.8 mm beyond the markers with 2 x 2 quadrature points a cell.
inline std::shared_ptr<const simulation::TwinBodyModel> SmallTwinBodyAt(double youngs_modulus_factor) {
  simulation::TwinBodyOptions options;
  options.margin_mm = 0.8;
  options.quadrature_points_per_side = 2;
  const TwinDeviation deviation{1.0, youngs_modulus_factor, 1.0};
  return std::make_shared<const simulation::TwinBodyModel>(
      simulation::CalcTwinBodyModel(simulation::TwinBodyModelOptions(SmallSensor(), deviation), options));
}

/// SmallTwinBodyAt(1.0), built once per test program.
inline std::shared_ptr<const simulation::TwinBodyModel> SmallTwinBody() {
  static const auto model = SmallTwinBodyAt(1.0);
  return model;
}

/// A sphere of radius 5 mm (mu 0.3) just touching the small sensor's fingertip top at the
/// identity pose, moved along `keyframes` (time s, translation mm) in `steps` steps.
inline Scene SphereScene(const std::vector<std::pair<double, Eigen::Vector3d>>& keyframes, int steps) {
  Scene scene;
  scene.name = "sphere";
  scene.sensor = SmallSensor();
  scene.deviation = {1.0, 1.0, 1.0};
  SceneObject sphere;
  sphere.name = "ball";
  sphere.shape = SceneObject::Shape::kSphere;
  sphere.radius_mm = 5.0;
  sphere.world_from_object = Rigid3(Eigen::Translation3d(0, 0, 3.0 + 5.0));
  sphere.friction.default_mu = 0.3;
  scene.objects.push_back(sphere);
  for (const auto& [t, p] : keyframes) {
    scene.trajectory.keyframes.push_back({t, Rigid3(Eigen::Translation3d(p))});
  }
  scene.trajectory.steps = steps;
  return scene;
}

}  // namespace tac3d::testing
