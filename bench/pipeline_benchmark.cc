// Image to TactileFrame per frame (issue: median <= 1 ms on one core): tracking, stereo,
// displacement, F = K D, normals, contact, resultants, on twin frames of a moving press.
// Run: taskset -c 0 build/bin/bench_pipeline --benchmark_repetitions=10
//        --benchmark_report_aggregates_only=true
#include <cmath>

#include <benchmark/benchmark.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d {
namespace {

void BM_ImageToTactileFrame(benchmark::State& state) {
  const SensorConfig config = DefaultSensorConfig();
  const std::vector<Eigen::Vector3d> rest = config.MarkerPositions();
  // H's values do not change the cost; the synthetic one saves building the FEM here.
  PipelineOptions options;
  options.reference_frames = 2;
  Pipeline pipeline(config, CalcSyntheticCompliance({}).h, rest, options);
  const MarkerImageRenderer renderer(config);
  std::vector<Frame> frames;
  for (int k = 0; k < 16; ++k) {
    std::vector<Eigen::Vector3d> markers = rest;
    const double depth_mm = 0.6 * (0.5 - 0.5 * std::cos(2 * M_PI * k / 16.0));
    for (auto& p : markers) p.z() -= depth_mm * std::exp(-p.head<2>().squaredNorm() / 18.0);
    frames.push_back({renderer.Render(markers, k), 0.0, k});
  }
  TactileFrame out;
  for (int k = 0; k < 2; ++k) pipeline.Process({renderer.Render(rest, 100 + k), 0.0, k}, out);
  size_t k = 0;
  for (auto _ : state) {
    pipeline.Process(frames[k++ % frames.size()], out);
    benchmark::DoNotOptimize(out.resultant_force_n);
  }
  if (out.has(FrameFlag::kInitializing) || out.has(FrameFlag::kMarkersLost)) state.SkipWithError("bad frame");
}
BENCHMARK(BM_ImageToTactileFrame)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
