// What publishing a frame on ROS 2 (tac3d run --ros2, docs/ros2.md) costs the sensor's thread:
// Ros2Publisher::Publish (the encoding; its own thread writes) of a 20 x 20-marker frame (WrenchStamped + PointCloud2, the status once
// in 30 frames as at 30 Hz), best effort or reliable, with no subscriber or with one in another
// process (a reader on loopback: the samples go out through the network stack).
//   build/bin/bench_ros2 --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <dds/dds.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/ros2/cdr_topic.h"
#include "tac3d/ros2/ros2_publisher.h"

namespace tac3d {
namespace {

constexpr int kDomain = 174;

// Loopback DDS on this benchmark's own domain.
void UseLoopbackDds() {
  const std::string path = "/tmp/tac3d_bench_ros2_cyclonedds.xml";
  std::ofstream(path) << R"(<CycloneDDS><Domain id="any"><General>
  <Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><Peers><Peer address="127.0.0.1"/></Peers><ParticipantIndex>auto</ParticipantIndex></Discovery>
</Domain></CycloneDDS>)";
  ::setenv("CYCLONEDDS_URI", ("file://" + path).c_str(), 1);
  ::setenv("ROS_DOMAIN_ID", std::to_string(kDomain).c_str(), 1);
}

// A process reading NAMESPACE's topics (best effort: it matches either profile) until killed.
// It only receives: the sertype of tac3d's topics decodes nothing, and Cyclone's complaint about
// each sample is silenced.
pid_t StartSubscriber(const std::string& ns) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  if (std::freopen("/dev/null", "w", stderr) == nullptr) ::_exit(1);
  const dds_entity_t participant = dds_create_participant(kDomain, nullptr, nullptr);
  for (const auto& [name, type] : {std::pair{"wrench", "geometry_msgs::msg::dds_::WrenchStamped_"},
                                   std::pair{"markers", "sensor_msgs::msg::dds_::PointCloud2_"},
                                   std::pair{"status", "diagnostic_msgs::msg::dds_::DiagnosticArray_"}}) {
    const internal::CdrTopic topic = internal::CreateCdrTopic(participant, "rt" + ns + "/" + name, type);
    dds_create_reader(participant, topic.topic, nullptr, nullptr);
  }
  ::pause();
  ::_exit(0);
}

void BM_PublishFrame(benchmark::State& state) {
  const bool reliable = state.range(0) != 0;
  const bool subscribed = state.range(1) != 0;
  UseLoopbackDds();
  const std::string ns = reliable ? "/bench/reliable" : "/bench/best_effort";
  const pid_t subscriber = subscribed ? StartSubscriber(ns) : 0;
  {
    Ros2Publisher publisher({.ns = ns, .reliable = reliable});
    if (subscribed) {
      for (int i = 0; i < 300 && publisher.subscribers() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    TactileFrame frame = MakeSyntheticTactileFrame("BENCH-20x20", 0, 20, 20);
    std::int64_t index = 0;
    for (auto _ : state) {
      frame.index = index;
      frame.timestamp_s = index / 30.0;  // 30 Hz: a status once in 30 frames
      publisher.Publish(frame, cv::Mat());
      ++index;
      // 1 ms between frames (a 1 kHz camera), untimed: the publisher's thread writes the samples
      // meanwhile, as it would between frames.
      state.PauseTiming();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      state.ResumeTiming();
    }
    state.counters["subscribers"] = publisher.subscribers();
    state.counters["failed_writes"] = static_cast<double>(publisher.stats().failed_writes);
  }
  if (subscriber > 0) {
    ::kill(subscriber, SIGTERM);
    ::waitpid(subscriber, nullptr, 0);
  }
}
BENCHMARK(BM_PublishFrame)
    ->ArgNames({"reliable", "subscribed"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 1})
    ->Unit(benchmark::kMicrosecond)
    ->Iterations(2000);  // 2 s of frames: the time between them is not timed

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
