// Triangulating the 400 tracked markers of one frame, with the refraction correction.
// Run: taskset -c 0 build/bin/bench_stereo --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/stereo/marker_field.h"

namespace tac3d {
namespace {

void BM_TriangulateFrame(benchmark::State& state) {
  const SensorConfig config = DefaultSensorConfig();
  MarkerTriangulatorOptions options;
  options.model = static_cast<RefractionModel>(state.range(0));
  const MarkerTriangulator triangulator(config, options);
  std::vector<Eigen::Vector2d> left, right;
  for (const auto& p : config.MarkerPositions()) {
    left.push_back(*triangulator.rig().Project(ImageHalf::kLeft, p));
    right.push_back(*triangulator.rig().Project(ImageHalf::kRight, p));
  }
  MarkerField field;
  for (auto _ : state) {
    triangulator.Triangulate(left, right, field);
    benchmark::DoNotOptimize(field.positions.data());
  }
}
// 0: no correction, 1: polynomial (the default), 2: exact.
BENCHMARK(BM_TriangulateFrame)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
