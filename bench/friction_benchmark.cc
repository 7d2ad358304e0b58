// A scanning session's friction map (paper IV.B): every frame through
// FrictionMapBuilder::AddFrame, then Build (resampling, Poisson at depth 8, trimming, mu per
// vertex), over the session's length in frames. The session: a plane pressed by a 20 x 20
// marker grid (4 mm contact radius, ~37 contact markers a frame), slid in 40 mm strokes at
// 0.08 mm a frame (the twin scenes' step), strokes 3 mm apart in y, 20% of the contact
// markers stuck each frame, 0.002 mm position and 0.5 mN force noise per axis (seeded).
// The session of 3000 frames (six strokes) must map in <= 10 s on one core.
// Run: OMP_WAIT_POLICY=PASSIVE taskset -c 0 build/bin/bench_friction
//      --benchmark_repetitions=3 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "tac3d/friction/friction_map.h"

namespace tac3d::friction {
namespace {

constexpr double kTopMm = 8.0;  // the outer surface's top in the sensor frame
constexpr double kCoverMm = 0.5;
constexpr double kStepMm = 0.08;
constexpr double kStrokeMm = 40.0;
constexpr double kContactRadiusMm = 4.0;

struct Session {
  std::vector<TactileFrame> frames;
  std::vector<Rigid3> poses;
};

Rigid3 SensorPose(double x_mm, double y_mm) {
  Rigid3 pose = Rigid3::Identity();
  pose.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(x_mm, y_mm, kTopMm);
  return pose;
}

// `frames` frames: strokes of kStrokeMm / kStepMm frames along +x, each after a lifted frame.
Session MakeSession(int frames) {
  Session s;
  std::mt19937_64 rng(20261124);
  std::normal_distribution<double> noise(0.0, 0.002), force_noise(0.0, 0.0005);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const int per_stroke = static_cast<int>(kStrokeMm / kStepMm) + 1;
  std::vector<Eigen::Vector3d> previous;
  for (int k = 0; static_cast<int>(s.frames.size()) < frames; ++k) {
    const int stroke = k / (per_stroke + 1), step = k % (per_stroke + 1) - 1;
    const Rigid3 pose =
        SensorPose(-0.5 * kStrokeMm + std::max(step, 0) * kStepMm, -7.5 + 3.0 * (stroke % 6));
    TactileFrame frame = TactileFrame::Sized(20, 20);
    frame.index = static_cast<std::int64_t>(s.frames.size());
    frame.timestamp_s = frame.index / 30.0;
    std::vector<Eigen::Vector3d> world(400, Eigen::Vector3d::Constant(std::nan("")));
    for (int i = 0; i < 400; ++i) {
      const Eigen::Vector2d q(((i % 20) - 9.5) * 1.27, ((i / 20) - 9.5) * 1.27);
      frame.positions_mm[i] =
          Eigen::Vector3d(q.x(), q.y(), kTopMm - kCoverMm - q.squaredNorm() / 90);
      frame.normals[i] = Eigen::Vector3d(q.x() / 45, q.y() / 45, 1).normalized();
      if (step < 0 || q.norm() >= kContactRadiusMm) continue;  // lifted, or out of contact
      const bool had = !previous.empty() && !std::isnan(previous[i].x());
      const bool stick = had && uniform(rng) < 0.2;
      const Eigen::Vector3d on_plane(q.x(), q.y(), kTopMm - kCoverMm);
      world[i] = stick ? previous[i] : Eigen::Vector3d(pose * on_plane);
      frame.positions_mm[i] =
          pose.inverse() * world[i] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      frame.normals[i] = Eigen::Vector3d::UnitZ();
      const double fn = 0.03 + 0.07 * std::sqrt(1 - q.squaredNorm() / 16.0);
      const double mu = (stick ? 0.5 : 1.0) * (world[i].x() < 0 ? 0.3 : 0.9);
      frame.forces_n[i] = Eigen::Vector3d(-mu * fn, 0, -fn) +
                          Eigen::Vector3d(force_noise(rng), force_noise(rng), force_noise(rng));
      frame.contact[i] = true;
    }
    previous = step < 0 ? std::vector<Eigen::Vector3d>{} : world;
    s.frames.push_back(std::move(frame));
    s.poses.push_back(pose);
  }
  return s;
}

// One thread for the reconstruction (the library's default): the acceptance is on one core.
void BM_FrictionMapSession(benchmark::State& state) {
  const Session session = MakeSession(static_cast<int>(state.range(0)));
  FrictionMapSummary summary;
  for (auto _ : state) {
    FrictionMapBuilder builder(FrictionMapOptions{});
    for (size_t k = 0; k < session.frames.size(); ++k)
      builder.AddFrame(session.frames[k], session.poses[k]);
    const FrictionMapResult map = builder.Build();
    summary = map.summary;
    benchmark::DoNotOptimize(map.mu.data());
  }
  state.counters["frames"] = summary.frames;
  state.counters["contact_points"] = summary.contact_points;
  state.counters["slip_points"] = summary.slip_points;
  state.counters["vertices"] = summary.vertices;
  state.counters["poisson_s"] = summary.poisson_time_s;
  state.counters["build_s"] = summary.total_time_s;
}

BENCHMARK(BM_FrictionMapSession)
    ->Arg(1000)
    ->Arg(3000)
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace
}  // namespace tac3d::friction

BENCHMARK_MAIN();
