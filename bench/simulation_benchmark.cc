// One twin simulation step (gap casting, contact solve, marker response, render) on a small
// body (5 x 5 markers, 0.42 mm cells) with a 10 mm sphere pressed 0.2 mm and sliding, over the
// contact grid's margin (grid sizes). The full-size figures (20 x 20 markers, the 500-step
// two_material_slide) are in docs/simulation.md, measured with `tac3d simulate`.
// Run: build/bin/bench_simulation --benchmark_repetitions=3 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <memory>

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/simulation/simulation.h"

namespace tac3d::simulation {
namespace {

SensorConfig SmallSensor() {
  SensorConfig sensor = DefaultSensorConfig();
  sensor.markers.rows = sensor.markers.cols = 5;
  sensor.elastic_body.base_diameter_mm = 16.0;
  sensor.elastic_body.thickness_mm = 4.0;
  sensor.elastic_body.outer_radius_mm = 25.0;
  return sensor;
}

Scene SlideScene() {
  Scene scene;
  scene.name = "bench";
  scene.sensor = SmallSensor();
  SceneObject sphere;
  sphere.name = "ball";
  sphere.radius_mm = 10.0;
  sphere.world_from_object = Rigid3(Eigen::Translation3d(0, 0, 4.0 + 10.0));
  scene.objects.push_back(sphere);
  scene.trajectory.keyframes = {{0.0, Rigid3(Eigen::Translation3d(-1, 0, 0.2))},
                                {1.0, Rigid3(Eigen::Translation3d(1, 0, 0.2))}};
  scene.trajectory.steps = 1000000;
  return scene;
}

void BM_SimulationStep(benchmark::State& state) {
  TwinBodyOptions options;
  options.margin_mm = static_cast<double>(state.range(0));
  const auto model = std::make_shared<const TwinBodyModel>(CalcTwinBodyModel(
      TwinBodyModelOptions(SmallSensor(), TwinDeviation{1.0, 1.1, 0.99}), options));
  SimulationOptions sim_options;
  sim_options.render_images = state.range(1) != 0;
  TwinSimulation sim(SlideScene(), model, sim_options);
  for (auto _ : state) benchmark::DoNotOptimize(sim.Step());
  const SimulationTimings& t = sim.summary().timings;
  const double steps = sim.summary().steps;
  state.counters["nodes"] = model->grid.num_nodes();
  state.counters["contact_ms"] = 1e3 * t.contact_s / steps;
  state.counters["response_ms"] = 1e3 * t.response_s / steps;
  state.counters["render_ms"] = 1e3 * t.render_s / steps;
  state.counters["max_tangential_iterations"] = sim.summary().max_tangential_iterations;
}
BENCHMARK(BM_SimulationStep)
    ->ArgsProduct({{1, 2}, {0, 1}})
    ->ArgNames({"margin_mm", "render"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tac3d::simulation

BENCHMARK_MAIN();
