// Per-frame cost of the Tac3D wire protocol: encoding a frame (rows x cols markers) into its
// datagrams, and the client's reassembly + decode of those datagrams (YAML header, fields).
// Run on one core: taskset -c 0 build/bin/bench_protocol --benchmark_repetitions=20
//   --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/protocol/frame_assembler.h"
#include "tac3d/protocol/wire_format.h"

namespace tac3d {
namespace {

void SetCounters(benchmark::State& state, int side, const EncodedFrame& encoded) {
  state.counters["markers"] = side * side;
  state.counters["datagrams"] = encoded.packet_count() + 1;
  state.counters["frames_per_s"] =
      benchmark::Counter(state.iterations(), benchmark::Counter::kIsRate);
}

void BM_Encode(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", 1, side, side);
  EncodedFrame encoded;
  std::uint32_t id = 0;
  for (auto _ : state) {
    EncodeFrame(frame, id++, cv::Mat(), ExtraItems(), &encoded);
    benchmark::DoNotOptimize(encoded.body.data());
  }
  SetCounters(state, side, encoded);
}
BENCHMARK(BM_Encode)->Arg(10)->Arg(20)->Arg(40);

void BM_ReassembleAndDecode(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  EncodedFrame encoded;
  EncodeFrame(
      MakeSyntheticTactileFrame("AD2-0065L", 1, side, side), 7, cv::Mat(), ExtraItems(), &encoded);
  const std::vector<std::string> datagrams = encoded.Datagrams();
  FrameAssembler assembler;
  const Endpoint sender{0x7f000001, 9000};
  for (auto _ : state) {
    std::optional<ReceivedFrame> out;
    for (const auto& d : datagrams) {
      out = assembler.Push(
          sender, std::span(reinterpret_cast<const std::uint8_t*>(d.data()), d.size()), 0.0);
    }
    if (!out) state.SkipWithError("the frame did not decode");
    benchmark::DoNotOptimize(out);
  }
  SetCounters(state, side, encoded);
}
BENCHMARK(BM_ReassembleAndDecode)->Arg(10)->Arg(20)->Arg(40);

// Decode alone (YAML header + fields), without reassembly.
void BM_Decode(benchmark::State& state) {
  EncodedFrame encoded;
  EncodeFrame(MakeSyntheticTactileFrame("AD2-0065L", 1), 7, cv::Mat(), ExtraItems(), &encoded);
  for (auto _ : state) benchmark::DoNotOptimize(DecodeFrame(encoded.header, encoded.body));
  SetCounters(state, 20, encoded);
}
BENCHMARK(BM_Decode);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
