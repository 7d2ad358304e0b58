// One quasi-static contact step on an elastic half-space, over grid resolutions (cells per
// Hertz radius a; the evaluation's fast test uses 10, its eval run 32): a sphere pressed with
// P = 1 N (normal problem from nothing), and Q = 0.5 mu P applied to the pressed state
// (tangential problem, the normal one warm-started). ShearOnALargeGrid: the same shear at 10
// cells per radius on a grid 4 times the contact's width (as in the twin, whose grid spans the
// fingertip), solved on a window around the contact (1) or on the whole grid (0).
// Run: build/bin/bench_contact --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "tac3d/contact/contact_solver.h"
#include "tac3d/contact/indenter.h"

namespace tac3d::contact {
namespace {

// The evaluation's geometry: R = 10 mm, P = 1 N, silicone E = 1 MPa, nu = 0.48, mu = 0.5.
struct Fixture {
  explicit Fixture(int cells_per_radius, double extent = 1.3, bool windowed = true) {
    const ElasticMaterial material{1.0, 0.48};
    const double a = std::cbrt(3.0 * 1.0 * 10.0 * (1.0 - 0.48 * 0.48) / 4.0);
    const double h = a / cells_per_radius;
    const int half = static_cast<int>(std::ceil(extent * a / h));
    grid = {2 * half + 1, 2 * half + 1, h, h};
    ContactSolverOptions options;
    options.windowed = windowed;
    solver = std::make_unique<ContactSolver>(std::make_shared<HalfSpaceCompliance>(grid, material),
                                             options);
    press.gap_mm = Indenter::Sphere(10.0).CalcGap(grid, Eigen::Vector2d::Zero());
    press.friction_coefficient = Eigen::VectorXd::Constant(grid.num_nodes(), 0.5);
    press.normal_force_n = 1.0;
  }
  SurfaceGrid grid;
  std::unique_ptr<ContactSolver> solver;
  ContactStep press;
};

void SetCounters(benchmark::State& state, const Fixture& f, const ContactSummary& s) {
  state.counters["nodes"] = f.grid.num_nodes();
  state.counters["normal_iterations"] = s.normal_iterations;
  state.counters["tangential_iterations"] = s.tangential_iterations;
  state.counters["coupling_iterations"] = s.coupling_iterations;
  state.counters["window_nodes"] = s.window_nx * s.window_ny;
}

void BM_Press(benchmark::State& state) {
  const Fixture f(static_cast<int>(state.range(0)));
  const ContactState unloaded = ContactState::Unloaded(f.grid.num_nodes());
  ContactSummary summary;
  for (auto _ : state) {
    const ContactResult r = f.solver->Solve(f.press, unloaded);
    summary = r.summary;
    benchmark::DoNotOptimize(r.state.pressure_mpa.data());
  }
  SetCounters(state, f, summary);
}

void Shear(benchmark::State& state, const Fixture& f) {
  const ContactState pressed =
      f.solver->Solve(f.press, ContactState::Unloaded(f.grid.num_nodes())).state;
  ContactStep shear = f.press;
  shear.tangential_force_n = Eigen::Vector2d(0.25, 0.0);
  ContactSummary summary;
  for (auto _ : state) {
    const ContactResult r = f.solver->Solve(shear, pressed);
    summary = r.summary;
    benchmark::DoNotOptimize(r.state.traction_mpa.data());
  }
  SetCounters(state, f, summary);
}

void BM_Shear(benchmark::State& state) { Shear(state, Fixture(static_cast<int>(state.range(0)))); }

void BM_ShearOnALargeGrid(benchmark::State& state) {
  Shear(state, Fixture(10, 4.0, state.range(0) != 0));
}

BENCHMARK(BM_Press)->Arg(10)->Arg(16)->Arg(32)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Shear)->Arg(10)->Arg(16)->Arg(32)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ShearOnALargeGrid)->ArgName("windowed")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tac3d::contact

BENCHMARK_MAIN();
