// Marker tracking on 640x480 twin frames of the built-in sensor: full-image acquisition
// (blob detection, grid indexing, growth), the per-frame tracking that follows it, and the
// whole per-frame chain up to the markers' 3D positions (tracking + triangulation), and a
// frame after a whole-grid jump of one pitch.
// Run: taskset -c 0 build/bin/bench_tracking --benchmark_repetitions=10
//        --benchmark_report_aggregates_only=true
#include <array>
#include <cmath>

#include <benchmark/benchmark.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/stereo/marker_field.h"
#include "tac3d/tracking/marker_tracker.h"
#include "tac3d/twin/camera_renderer.h"

namespace tac3d {
namespace {

const SensorConfig& Sensor() {
  static const SensorConfig config = DefaultSensorConfig();
  return config;
}

// A shear sweeping back and forth across 16 frames, up to 1 mm at the centre (about 0.1
// pitch between frames): every frame moves every tracked marker.
const std::vector<cv::Mat>& Frames() {
  static const std::vector<cv::Mat> frames = [] {
    const MarkerImageRenderer renderer(Sensor());
    std::vector<cv::Mat> out;
    for (int k = 0; k < 16; ++k) {
      auto markers = Sensor().MarkerPositions();
      const double amplitude_mm = std::sin(2 * M_PI * k / 16.0);
      for (auto& p : markers) p.x() += amplitude_mm * std::exp(-p.head<2>().squaredNorm() / 72.0);
      out.push_back(renderer.Render(markers, k));
    }
    return out;
  }();
  return frames;
}

void BM_DetectBlobsOneHalf(benchmark::State& state) {
  const VirtualCameraConfig& camera = Sensor().virtual_cameras.front();
  const cv::Rect roi(camera.column_begin, 0, camera.column_end - camera.column_begin, 480);
  for (auto _ : state) benchmark::DoNotOptimize(DetectBlobs(Frames()[0], roi, {}));
}
BENCHMARK(BM_DetectBlobsOneHalf)->Unit(benchmark::kMillisecond);

// First frame (and re-acquisition): detection + indexing + growth in both halves.
void BM_AcquireFrame(benchmark::State& state) {
  MarkerTracker tracker(Sensor());
  MarkerObservation observation;
  for (auto _ : state) {
    tracker.Reset();
    tracker.Track(Frames()[0], observation);
    if (observation.summary.paired_markers != 400) state.SkipWithError("grid not acquired");
  }
}
BENCHMARK(BM_AcquireFrame)->Unit(benchmark::kMillisecond);

// Every later frame: 800 markers predicted, measured in small windows, gated.
void BM_TrackFrame(benchmark::State& state) {
  MarkerTracker tracker(Sensor());
  MarkerObservation observation;
  tracker.Track(Frames()[0], observation);
  size_t k = 1;
  for (auto _ : state) {
    tracker.Track(Frames()[k++ % Frames().size()], observation);
    if (observation.summary.acquired || observation.summary.paired_markers != 400) {
      state.SkipWithError("tracking lost markers");
    }
  }
  state.counters["markers"] = 2.0 * observation.rows * observation.cols;
}
BENCHMARK(BM_TrackFrame)->Unit(benchmark::kMicrosecond);

// The per-frame chain of a tracked frame: tracking in both halves, pairing by index (a
// marker's uv is NaN unless valid in its half, so the triangulator keeps the markers valid
// in both) and triangulation with the polynomial refraction compensation.
void BM_TrackAndTriangulateFrame(benchmark::State& state) {
  MarkerTracker tracker(Sensor());
  const MarkerTriangulator triangulator(Sensor());
  MarkerObservation observation;
  MarkerField field;
  tracker.Track(Frames()[0], observation);
  size_t k = 1;
  for (auto _ : state) {
    tracker.Track(Frames()[k++ % Frames().size()], observation);
    triangulator.Triangulate(observation.half(ImageHalf::kLeft).uv,
                             observation.half(ImageHalf::kRight).uv, field);
    if (observation.summary.acquired || field.CountValid() != 400) {
      state.SkipWithError("markers lost");
    }
  }
}
BENCHMARK(BM_TrackAndTriangulateFrame)->Unit(benchmark::kMicrosecond);

// A frame after the whole grid jumped by one pitch (x, alternately forth and back): the
// border check finds it and the half is re-acquired, so this is what a jump costs.
void BM_TrackFrameAfterPitchJump(benchmark::State& state) {
  static const std::array<cv::Mat, 2> frames = [] {
    const MarkerImageRenderer renderer(Sensor());
    auto jumped = Sensor().MarkerPositions();
    for (auto& p : jumped) p.x() += Sensor().markers.pitch_mm;
    return std::array<cv::Mat, 2>{renderer.Render(Sensor().MarkerPositions(), 0),
                                  renderer.Render(jumped, 1)};
  }();
  MarkerTracker tracker(Sensor());
  MarkerObservation observation;
  tracker.Track(frames[0], observation);
  size_t k = 1;
  for (auto _ : state) {
    tracker.Track(frames[k++ % 2], observation);
    if (!observation.summary.acquired || observation.summary.paired_markers != 400) {
      state.SkipWithError("jump not re-acquired");
    }
  }
}
BENCHMARK(BM_TrackFrameAfterPitchJump)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
