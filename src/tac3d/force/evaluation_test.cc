#include "tac3d/force/evaluation.h"

#include <gtest/gtest.h>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

TEST(EvalForceOptions, EveryBoundIsChecked) {
  EXPECT_NO_THROW(EvalForceOptions{}.Validate());
  const auto expect_throw = [](auto change) {
    EvalForceOptions options;
    change(options);
    EXPECT_THROW(options.Validate(), Error);
  };
  expect_throw([](EvalForceOptions& o) { o.truth_refinement = 0.9; });
  expect_throw([](EvalForceOptions& o) { o.truth_refinement = 4.5; });
  expect_throw([](EvalForceOptions& o) { o.truth_modulus_factor = 0.0; });
  expect_throw([](EvalForceOptions& o) { o.truth_poisson_factor = 2.5; });
  expect_throw([](EvalForceOptions& o) { o.truth_poisson_factor = 1.05; });  // nu > 0.4999
  expect_throw([](EvalForceOptions& o) { o.noise_mm = -0.001; });
  expect_throw([](EvalForceOptions& o) { o.static_frames = 1; });
  expect_throw([](EvalForceOptions& o) { o.calibration_presses = 2; });
  expect_throw([](EvalForceOptions& o) { o.test_presses = 2; });
  expect_throw([](EvalForceOptions& o) { o.full_scale_normal_n = 0.0; });
  expect_throw([](EvalForceOptions& o) { o.full_scale_tangential_n = -5.0; });
  expect_throw([](EvalForceOptions& o) { o.body.thickness_mm = -1.0; });
  expect_throw([](EvalForceOptions& o) { o.weight.discrepancy_factor = 0.5; });
  expect_throw([](EvalForceOptions& o) { o.contact.contact_threshold_n = -1.0; });
  EXPECT_THROW(EvaluateForce([] {
                 EvalForceOptions o;
                 o.noise_mm = NAN;
                 return o;
               }()),
               Error);
}

}  // namespace
}  // namespace tac3d
