// Per-frame cost of the force inverse F = K D (paper eq. 4) over grid sizes, against the bare
// double- and single-precision GEMV it is built on, with and without invalid markers (the same
// mask every frame, a new one, one changing by a few markers); and of F = K D followed by the
// contact-support re-solve, over the size of the press, held or moving.
// Run on one core: taskset -c 0 build/bin/bench_force --benchmark_repetitions=20
//   --benchmark_report_aggregates_only=true

#include <cmath>
#include <memory>
#include <random>

#include <benchmark/benchmark.h>

#include "tac3d/force/force_reconstructor.h"
#include "tac3d/force/synthetic_compliance.h"

namespace tac3d {
namespace {

// A reconstructor for a side x side grid and a displacement frame (the values do not matter
// to the timing; a half-space H keeps K realistic).
struct Fixture {
  explicit Fixture(int side) {
    const SyntheticCompliance model = CalcSyntheticCompliance({.rows = side, .cols = side});
    h = model.h;
    reconstructor = std::make_unique<ForceReconstructor>(
        model.h, model.marker_positions,
        ForceReconstructorOptions{.weight = 1e-3, .support_refinement = false});
    markers = model.marker_positions;
    std::mt19937_64 rng(1);
    std::normal_distribution<double> normal(0.0, 0.01);
    d.resize(h.rows());
    for (Eigen::Index j = 0; j < d.size(); ++j) d(j) = normal(rng);
  }

  // 10% of the markers lost, at random.
  std::vector<bool> Mask(std::uint64_t seed) const {
    std::mt19937_64 rng(seed);
    const int n = reconstructor->num_markers();
    std::vector<bool> valid(n, true);
    for (int k = 0; k < n / 10;) {
      const int i = static_cast<int>(rng() % n);
      if (valid[i]) valid[i] = false, ++k;
    }
    return valid;
  }

  Eigen::MatrixXd h;
  std::vector<Eigen::Vector3d> markers;
  std::unique_ptr<ForceReconstructor> reconstructor;
  Eigen::VectorXd d;
};

void SetCounters(benchmark::State& state, int side) {
  state.counters["markers"] = side * side;
  state.counters["frames_per_s"] = benchmark::Counter(state.iterations(), benchmark::Counter::kIsRate);
}

void BM_Reconstruct(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  Fixture fixture(side);
  ForceFrame frame;
  for (auto _ : state) {
    fixture.reconstructor->Reconstruct(fixture.d, {}, &frame);
    benchmark::DoNotOptimize(frame.forces_n.data());
  }
  SetCounters(state, side);
}
BENCHMARK(BM_Reconstruct)->Arg(10)->Arg(20)->Arg(30)->Unit(benchmark::kMicrosecond);

// Displacements of a Hertz-like 5 N press of radius radius_mm centred at (centre_x_mm, 0) on
// the 20 x 20 grid (1.27 mm pitch), with 0.005 mm noise.
Eigen::VectorXd PressDisplacements(const Fixture& fixture, double radius_mm, double centre_x_mm) {
  Eigen::VectorXd press = Eigen::VectorXd::Zero(fixture.h.rows());
  const int n = static_cast<int>(fixture.markers.size());
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d offset = fixture.markers[i].head<2>() - Eigen::Vector2d(centre_x_mm, 0.0);
    const double r2 = offset.squaredNorm() / (radius_mm * radius_mm);
    if (r2 < 1.0) press(2 * n + i) = -std::sqrt(1.0 - r2), total += std::sqrt(1.0 - r2);
  }
  press *= 5.0 / total;
  Eigen::VectorXd d = fixture.h * press;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 0.005);
  for (Eigen::Index j = 0; j < d.size(); ++j) d(j) += normal(rng);
  return d;
}

// F = K D, then the re-solve on the contact support of a press of radius range(0) / 10 mm
// (400 markers); the support's size is a counter. The same frame every time: the support does
// not change, and its factor is reused.
void BM_ReconstructWithSupport(benchmark::State& state) {
  Fixture fixture(20);
  ForceReconstructor reconstructor(fixture.h, fixture.markers,
                                   ForceReconstructorOptions{.weight = 1e-3});
  const Eigen::VectorXd d = PressDisplacements(fixture, state.range(0) / 10.0, 0.0);
  ForceFrame frame;
  for (auto _ : state) {
    reconstructor.Reconstruct(d, {}, &frame);
    benchmark::DoNotOptimize(frame.forces_n.data());
  }
  SetCounters(state, 20);
  state.counters["support_markers"] = frame.num_support_markers;
}
BENCHMARK(BM_ReconstructWithSupport)->Arg(15)->Arg(30)->Arg(45)->Unit(benchmark::kMicrosecond);

// The same, the press moving by one pitch every frame: a new support, refactored each frame.
void BM_ReconstructWithMovingSupport(benchmark::State& state) {
  Fixture fixture(20);
  ForceReconstructor reconstructor(fixture.h, fixture.markers,
                                   ForceReconstructorOptions{.weight = 1e-3});
  const double radius_mm = state.range(0) / 10.0;
  const Eigen::VectorXd d[2] = {PressDisplacements(fixture, radius_mm, 0.0),
                                PressDisplacements(fixture, radius_mm, 1.27)};
  ForceFrame frame;
  int k = 0;
  for (auto _ : state) {
    reconstructor.Reconstruct(d[k++ % 2], {}, &frame);
    benchmark::DoNotOptimize(frame.forces_n.data());
  }
  SetCounters(state, 20);
  state.counters["support_markers"] = frame.num_support_markers;
}
BENCHMARK(BM_ReconstructWithMovingSupport)->Arg(15)->Arg(30)->Arg(45)->Unit(benchmark::kMicrosecond);

// The same mask every frame: the cached restricted factor is reused.
void BM_ReconstructTenPercentInvalid(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  Fixture fixture(side);
  const std::vector<bool> valid = fixture.Mask(2);
  ForceFrame frame;
  for (auto _ : state) {
    fixture.reconstructor->Reconstruct(fixture.d, valid, &frame);
    benchmark::DoNotOptimize(frame.forces_n.data());
  }
  SetCounters(state, side);
}
BENCHMARK(BM_ReconstructTenPercentInvalid)->Arg(20)->Unit(benchmark::kMicrosecond);

// A different mask every frame, two independent draws of 10% (about 70 markers differ): the
// restricted problem is refactored each time.
void BM_ReconstructNewMaskEveryFrame(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  Fixture fixture(side);
  const std::vector<bool> masks[2] = {fixture.Mask(2), fixture.Mask(3)};
  ForceFrame frame;
  int k = 0;
  for (auto _ : state) {
    fixture.reconstructor->Reconstruct(fixture.d, masks[k++ % 2], &frame);
    benchmark::DoNotOptimize(frame.forces_n.data());
  }
  SetCounters(state, side);
}
BENCHMARK(BM_ReconstructNewMaskEveryFrame)->Arg(20)->Unit(benchmark::kMicrosecond);

// Two masks alternating that differ in range(0) markers (half lost, half recovered): markers
// flickering at a contact's edge.
void BM_ReconstructMaskChangingBy(benchmark::State& state) {
  Fixture fixture(20);
  const int changes = static_cast<int>(state.range(0));
  std::vector<bool> masks[2] = {fixture.Mask(2), fixture.Mask(2)};
  std::mt19937_64 rng(4);
  const int n = fixture.reconstructor->num_markers();
  for (int k = 0; k < changes;) {
    const int i = static_cast<int>(rng() % n);
    // Lose a valid marker on even k, recover a lost one on odd k.
    if (masks[1][i] == (k % 2 == 0)) masks[1][i] = !masks[1][i], ++k;
  }
  ForceFrame frame;
  int k = 0;
  for (auto _ : state) {
    fixture.reconstructor->Reconstruct(fixture.d, masks[k++ % 2], &frame);
    benchmark::DoNotOptimize(frame.forces_n.data());
  }
  SetCounters(state, 20);
}
BENCHMARK(BM_ReconstructMaskChangingBy)->Arg(1)->Arg(5)->Arg(20)->Unit(benchmark::kMicrosecond);

// The bare products, to show what single precision buys: K is 3N x 3N, read once a frame.
template <typename Scalar>
void BM_Gemv(benchmark::State& state) {
  const int n = 3 * static_cast<int>(state.range(0) * state.range(0));
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  const Matrix k = Matrix::Random(n, n);
  const Vector d = Vector::Random(n);
  Vector f(n);
  for (auto _ : state) {
    f.noalias() = k * d;
    benchmark::DoNotOptimize(f.data());
  }
  state.counters["bytes_of_K"] = static_cast<double>(sizeof(Scalar)) * n * n;
}
BENCHMARK(BM_Gemv<double>)->Arg(20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Gemv<float>)->Arg(20)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
