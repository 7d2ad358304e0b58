#include "tac3d/eval/force_evaluation.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace tac3d
