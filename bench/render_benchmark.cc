// Rendering one 640x480 frame of the marker layer with the twin's camera.
// Run: build/bin/bench_render --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d {
namespace {

const SensorConfig& Sensor() {
  static const SensorConfig config = DefaultSensorConfig();
  return config;
}

void BM_RenderMarkerFrame(benchmark::State& state) {
  const MarkerImageRenderer renderer(Sensor());
  auto markers = Sensor().MarkerPositions();
  std::uint64_t frame = 0;
  for (auto _ : state) {
    // A little shear each frame so nothing is cached between frames.
    for (auto& p : markers) p.x() += 1e-4;
    benchmark::DoNotOptimize(renderer.Render(markers, frame++));
  }
}
BENCHMARK(BM_RenderMarkerFrame)->Unit(benchmark::kMillisecond);

void BM_RenderBoardFrame(benchmark::State& state) {
  const BoardImageRenderer renderer(Sensor());
  DotBoard board;
  Rigid3 pose = Rigid3::Identity();
  pose.translation() = Eigen::Vector3d(-9, -9, 0);
  for (auto _ : state) benchmark::DoNotOptimize(renderer.Render(board, pose));
}
BENCHMARK(BM_RenderBoardFrame)->Unit(benchmark::kMillisecond);

void BM_BuildMarkerRenderer(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(MarkerImageRenderer(Sensor()));
}
BENCHMARK(BM_BuildMarkerRenderer)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
