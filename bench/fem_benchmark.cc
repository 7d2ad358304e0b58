// FEM benchmarks: the element stiffness, assembly + factorisation over mesh sizes, H alone on
// a factored body, and the full build of the default sensor's compliance matrix H (run them
// alone: the default sensor's take ~15 s each):
//   build/bin/bench_fem --benchmark_filter='ComplianceMatrix|DefaultSensor'
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>

#include "tac3d/fem/body_model.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/fem/hex8.h"

namespace tac3d::fem {
namespace {

void BM_Hex8Stiffness(benchmark::State& state) {
  Hex8Nodes x;
  x << 0, 0, 0, 1, 0.1, 0, 1.1, 1, 0, 0, 0.9, 0.1, 0, 0, 1, 1, 0, 1.2, 1, 1, 1, -0.1, 1, 0.9;
  const ElasticMaterial material;
  for (auto _ : state) benchmark::DoNotOptimize(CalcHex8Stiffness(x, material));
}
BENCHMARK(BM_Hex8Stiffness);

// Meshing, assembly and factorisation of the default dome at refinement range(0) / 4.
void BM_DomeAssembleAndFactor(benchmark::State& state) {
  BodyModelOptions options;
  options.refinement = state.range(0) / 4.0;
  for (auto _ : state) {
    const BodyModel model(options);
    const ElasticSolverSummary& summary = model.solver().summary();
    state.counters["free_dofs"] = summary.num_free_dofs;
    state.counters["assembly_s"] = summary.assembly_s;
    state.counters["factor_s"] = summary.factorization_s;
    state.counters["factor_nnz"] = summary.factor_nonzeros;
  }
}
BENCHMARK(BM_DomeAssembleAndFactor)
    ->Arg(2)
    ->Arg(3)
    ->Arg(4)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// H alone, the body meshed and factored beforehand: the small test dome with 4 x 5 markers
// (range(0) = 0) and the default sensor (range(0) = 1; 400 markers, 1200 load cases).
void BM_ComplianceMatrix(benchmark::State& state) {
  BodyModelOptions options;
  if (state.range(0) == 0) {
    options.base_diameter_mm = 12.0;
    options.thickness_mm = 3.0;
    options.sphere_radius_mm = 20.0;
    options.marker_rows = 4;
    options.marker_cols = 5;
  }
  const BodyModel model(options);
  for (auto _ : state) {
    const ComplianceModel compliance = CalcComplianceModel(model);
    state.counters["solves_s"] = compliance.provenance.solves_s;
  }
  state.counters["free_dofs"] = model.solver().summary().num_free_dofs;
  state.counters["load_cases"] = 3 * options.num_markers();
}
BENCHMARK(BM_ComplianceMatrix)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The default sensor's H (400 markers, 1200 load cases), from options to matrix.
void BM_DefaultSensorComplianceBuild(benchmark::State& state) {
  for (auto _ : state) {
    const ComplianceModel model = CalcComplianceModel(BodyModelOptions{});
    state.counters["free_dofs"] = model.provenance.num_free_dofs;
    state.counters["assembly_s"] = model.provenance.assembly_s;
    state.counters["factor_s"] = model.provenance.factorization_s;
    state.counters["solves_s"] = model.provenance.solves_s;
  }
}
BENCHMARK(BM_DefaultSensorComplianceBuild)->Unit(benchmark::kSecond)->Iterations(1);

// Loading a cached H of the default sensor's size (1200 x 1200; the matrix is random, which
// costs the same to read and checksum).
void BM_DefaultSensorCacheLoad(benchmark::State& state) {
  ComplianceModel model;
  model.h = Eigen::MatrixXd::Random(1200, 1200);
  const std::string path = "/tmp/tac3d_bench_fem_cache.bin";
  SaveComplianceModel(model, path);
  for (auto _ : state) benchmark::DoNotOptimize(LoadComplianceModel(path).h.data());
  std::remove(path.c_str());
}
BENCHMARK(BM_DefaultSensorCacheLoad)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tac3d::fem

BENCHMARK_MAIN();
