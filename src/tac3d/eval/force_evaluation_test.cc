#include "tac3d/eval/force_evaluation.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "tac3d/testing/testing.h"
#include "tac3d/util/cache_file.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

TEST(EvalForceOptions, TrueMaterialScalesTheShearAndBulkModuli) {
  EvalForceOptions options;
  const ElasticMaterial nominal = options.body.material;
  const auto bulk = [](const ElasticMaterial& m) {
    return m.youngs_modulus_mpa / (3.0 * (1.0 - 2.0 * m.poisson_ratio));
  };
  const ElasticMaterial truth = options.TrueMaterial();
  EXPECT_NEAR(truth.shear_modulus() / nominal.shear_modulus(), 1.1, 1e-12);
  EXPECT_NEAR(bulk(truth) / bulk(nominal), 0.9, 1e-12);
  // nu x 0.9 with E x 1.1 from the nominal 0.48, in these terms (docs/force.md).
  options.truth_shear_modulus_factor = 1.1 * 1.48 / 1.432;
  options.truth_bulk_modulus_factor = 1.1 * 0.04 / 0.136;
  EXPECT_NEAR(options.TrueMaterial().poisson_ratio, 0.432, 1e-12);
  EXPECT_NEAR(options.TrueMaterial().youngs_modulus_mpa, 1.1, 1e-12);
}

TEST(EvalForceOptions, SetTrueMaterialInvertsTrueMaterial) {
  EvalForceOptions options;
  options.SetTrueMaterial({1.2, 0.45});
  EXPECT_NEAR(options.TrueMaterial().youngs_modulus_mpa, 1.2, 1e-12);
  EXPECT_NEAR(options.TrueMaterial().poisson_ratio, 0.45, 1e-12);
}

TEST(EvalForceOptions, EveryBoundIsChecked) {
  EXPECT_NO_THROW(EvalForceOptions{}.Validate());
  const auto expect_throw = [](auto change) {
    EvalForceOptions options;
    change(options);
    EXPECT_THROW(options.Validate(), Error);
  };
  expect_throw([](EvalForceOptions& o) { o.truth_refinement = 0.9; });
  expect_throw([](EvalForceOptions& o) { o.truth_refinement = 4.5; });
  expect_throw([](EvalForceOptions& o) { o.truth_shear_modulus_factor = 0.0; });
  // K x 1000 takes nu from 0.48 to 0.49992, past the element's bound.
  expect_throw([](EvalForceOptions& o) { o.truth_bulk_modulus_factor = 1e3; });
  expect_throw([](EvalForceOptions& o) { o.truth_shear_modulus_factor = INFINITY; });
  // From nu = 0.4999, a stiffer K takes the true nu past the element's bound.
  expect_throw([](EvalForceOptions& o) {
    o.body.material.poisson_ratio = 0.4999;
    o.truth_bulk_modulus_factor = 1.5;
  });
  expect_throw([](EvalForceOptions& o) { o.noise_mm = -0.001; });
  expect_throw([](EvalForceOptions& o) { o.static_frames = 1; });
  expect_throw([](EvalForceOptions& o) { o.calibration_presses = 2; });
  expect_throw([](EvalForceOptions& o) { o.test_presses = 2; });
  // A billion presses were accepted: hours of solves before any output.
  expect_throw([](EvalForceOptions& o) { o.calibration_presses = 1000000000; });
  expect_throw([](EvalForceOptions& o) { o.test_presses = 10001; });
  expect_throw([](EvalForceOptions& o) { o.static_frames = 10001; });
  expect_throw([](EvalForceOptions& o) { o.full_scale_normal_n = 0.0; });
  expect_throw([](EvalForceOptions& o) { o.full_scale_tangential_n = -5.0; });
  expect_throw([](EvalForceOptions& o) { o.body.thickness_mm = -1.0; });
  expect_throw([](EvalForceOptions& o) { o.weight.discrepancy_factor = 0.5; });
  expect_throw([](EvalForceOptions& o) { o.contact.contact_threshold_n = -1.0; });
  expect_throw([](EvalForceOptions& o) { o.material.max_poisson_error = 0.0; });
  expect_throw([](EvalForceOptions& o) { o.poisson_nodes = {0.45, 0.5}; });
  expect_throw([](EvalForceOptions& o) {
    o.calibrate_material = true;
    o.poisson_nodes = {0.48};
  });
  EXPECT_THROW(EvaluateForce([] {
                 EvalForceOptions o;
                 o.noise_mm = NAN;
                 return o;
               }()),
               Error);
}

// A coarse mesh (refinement 0.25, the truth on the same mesh) and three presses of each kind, so
// an evaluation takes seconds.
EvalForceOptions SmallEvaluation() {
  EvalForceOptions options;
  options.body.refinement = 0.25;
  options.truth_refinement = 1.0;
  options.calibration_presses = 3;
  options.test_presses = 3;
  options.show_progress = false;
  return options;
}

// The grid's points reuse one true model a Poisson's ratio, its responses scaled by 1 / E: each
// point must give what a run of its own gives (SmallEvaluation).
TEST(EvaluateForceOverMaterials, EachPointEqualsARunOfItsOwn) {
  EvalForceOptions options = SmallEvaluation();
  const MaterialGrid grid{.youngs_modulus_factors = {0.8, 1.2}, .poisson_ratios = {0.45}};
  const std::vector<ForceEvaluation> points = EvaluateForceOverMaterials(options, grid);
  ASSERT_EQ(points.size(), 2u);
  for (size_t k = 0; k < points.size(); ++k) {
    EvalForceOptions own = options;
    own.SetTrueMaterial({grid.youngs_modulus_factors[k] * options.body.material.youngs_modulus_mpa,
                         0.45});
    const ForceEvaluation direct = EvaluateForce(own);
    const ForceEvaluation& point = points[k];
    EXPECT_NEAR(point.true_material.youngs_modulus_mpa, own.TrueMaterial().youngs_modulus_mpa,
                1e-12);
    EXPECT_EQ(point.details.at("presses").at("test").size(), 3u);
    EXPECT_THAT(point.resultant_error_max_pct_fs, EigenNear(direct.resultant_error_max_pct_fs, 1e-6))
        << "at E x " << grid.youngs_modulus_factors[k];
    EXPECT_THAT(point.resultant_error_rms_pct_fs, EigenNear(direct.resultant_error_rms_pct_fs, 1e-6));
    EXPECT_NEAR(point.probe_center_error_mm, direct.probe_center_error_mm, 1e-6);
    EXPECT_NEAR(point.weight.weight, direct.weight.weight, 1e-9 * direct.weight.weight);
    ASSERT_EQ(point.checks.size(), 4u);
    EXPECT_EQ(point.checks[0].name, "resultant_error_pct_fs");
  }
  // The two materials differ, so the scaling did something: E x 1.2 is not E x 0.8.
  EXPECT_GT((points[0].resultant_error_max_pct_fs - points[1].resultant_error_max_pct_fs).norm(),
            1e-6);
}

// The true responses are cached chunk by chunk: a second run loads them all, a run stopped
// with cases unsolved resumes with them, and a damaged file is solved again; every run gives
// the same figures (SmallEvaluation: 14 load cases).
TEST(EvaluateForce, CachesTheTruthAndResumesAStoppedSolve) {
  EvalForceOptions options = SmallEvaluation();
  options.cache_dir = testing::MakeTempDir("force_truth_cache");
  const auto from_cache = [](const ForceEvaluation& e) {
    return e.details.at("timing_s").at("truth_cases_from_cache").get<int>();
  };
  const auto expect_same = [](const ForceEvaluation& a, const ForceEvaluation& b) {
    EXPECT_THAT(a.resultant_error_max_pct_fs, EigenNear(b.resultant_error_max_pct_fs, 1e-12));
    EXPECT_NEAR(a.probe_center_error_mm, b.probe_center_error_mm, 1e-12);
  };
  const ForceEvaluation first = EvaluateForce(options);
  EXPECT_EQ(from_cache(first), 0);
  std::string path;
  for (const auto& entry : std::filesystem::directory_iterator(options.cache_dir)) {
    if (entry.path().filename().string().starts_with("force_truth_")) path = entry.path().string();
  }
  ASSERT_FALSE(path.empty());

  const ForceEvaluation loaded = EvaluateForce(options);
  EXPECT_EQ(from_cache(loaded), 14);
  expect_same(loaded, first);

  // As if stopped after the first chunk: the second chunk's cases unsolved, their columns lost.
  CacheRecord record = ReadCacheRecord(path, "TAC3DFTR", 1);
  ASSERT_EQ(record.matrices.at(0).cols(), 14);
  for (int c = 7; c < 14; ++c) {
    record.header["solved"][c] = false;
    record.matrices[0].col(c).setZero();
  }
  WriteCacheRecord(path, "TAC3DFTR", 1, record);
  const ForceEvaluation resumed = EvaluateForce(options);
  EXPECT_EQ(from_cache(resumed), 7);
  expect_same(resumed, first);

  std::filesystem::resize_file(path, std::filesystem::file_size(path) / 2);
  const ForceEvaluation damaged = EvaluateForce(options);
  EXPECT_EQ(from_cache(damaged), 0);
  expect_same(damaged, first);
  EXPECT_EQ(from_cache(EvaluateForce(options)), 14);  // the damaged file was replaced
}

TEST(MaterialGrid, RefusesAnEmptyListAndABadFactor) {
  EXPECT_NO_THROW(MaterialGrid{}.Validate());
  EXPECT_THROW((MaterialGrid{.youngs_modulus_factors = {}}).Validate(), Error);
  EXPECT_THROW((MaterialGrid{.poisson_ratios = {}}).Validate(), Error);
  EXPECT_THROW((MaterialGrid{.youngs_modulus_factors = {1.0, -0.5}}).Validate(), Error);
  // A point's material is checked before any solve: nu 0.6 is not a material.
  EXPECT_THROW(EvaluateForceOverMaterials(EvalForceOptions{}, {.poisson_ratios = {0.48, 0.6}}),
               Error);
}

}  // namespace
}  // namespace tac3d
