// Reading a recording with the C++ reader, frame by frame: the baseline the Python bindings'
// per-frame overhead is measured against (python/bench/recording_overhead.py, docs/python.md).
// The recording is $TAC3D_BENCH_RECORDING if set, else a 10,000-frame one written here.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tac3d/record/recording.h"

namespace tac3d {
namespace {

std::string RecordingPath() {
  if (const char* path = std::getenv("TAC3D_BENCH_RECORDING"); path && *path) return path;
  const std::string path =
      (std::filesystem::temp_directory_path() / "tac3d_bench_recording.tac3drec").string();
  RecordingWriter writer(path, {.overwrite = true});
  TactileFrame frame = TactileFrame::Sized(20, 20);
  frame.sn = "BENCH";
  for (int k = 0; k < 10000; ++k) {
    frame.index = k;
    frame.timestamp_s = 0.001 * k;
    frame.positions_mm[k % 400].x() = k;
    writer.Write(frame);
  }
  return path;
}

void BM_ReadRecording(benchmark::State& state) {
  static const std::string path = RecordingPath();
  std::int64_t frames = 0;
  for (auto _ : state) {
    RecordingReader reader(path);
    while (std::optional<RecordedFrame> f = reader.Next()) {
      benchmark::DoNotOptimize(f->frame.positions_mm.data());
      ++frames;
    }
  }
  state.SetItemsProcessed(frames);
  state.counters["us_per_frame"] = benchmark::Counter(
      static_cast<double>(frames), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["us_per_frame"] = state.counters["us_per_frame"].value * 1e6;
}
BENCHMARK(BM_ReadRecording)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
