#include "tac3d/force/regularization.h"

#include <cmath>
#include <random>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/force/test_loads.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

Eigen::VectorXd GaussianNoise(int size, const Eigen::Vector3d& sigma, std::mt19937_64* rng) {
  std::normal_distribution<double> normal;
  Eigen::VectorXd e(size);
  for (int j = 0; j < size; ++j) e(j) = sigma(j / (size / 3)) * normal(*rng);
  return e;
}

TEST(EstimateDisplacementNoise, RecoversPerAxisVarianceAboutEachMarkersMean) {
  std::mt19937_64 rng(testing::kRandomSeed);
  const int n = 300;  // 100 markers
  const Eigen::Vector3d sigma(0.005, 0.004, 0.010);
  const Eigen::VectorXd offset = Eigen::VectorXd::LinSpaced(n, -0.2, 0.3);  // a stale reference
  std::vector<Eigen::VectorXd> frames;
  for (int k = 0; k < 50; ++k) frames.push_back(offset + GaussianNoise(n, sigma, &rng));
  frames[3](7) = NAN;  // a lost sample is skipped, not counted
  const DisplacementNoise noise = EstimateDisplacementNoise(frames);
  EXPECT_EQ(noise.num_frames, 50);
  EXPECT_EQ(noise.degrees_of_freedom, Eigen::Vector3i(100 * 49 - 1, 100 * 49, 100 * 49));
  // 4900 degrees of freedom: the variance's relative standard deviation is sqrt(2/4900) = 2%.
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(noise.variance_mm2(axis) / (sigma(axis) * sigma(axis)), 1.0, 0.08) << axis;
  }
}

TEST(EstimateDisplacementNoise, BadStacksThrow) {
  const Eigen::VectorXd frame = Eigen::VectorXd::Zero(6);
  EXPECT_THROW(EstimateDisplacementNoise({frame}), Error);
  EXPECT_THROW(EstimateDisplacementNoise({frame, Eigen::VectorXd::Zero(9)}), Error);
  EXPECT_THROW(EstimateDisplacementNoise({Eigen::VectorXd::Zero(5), Eigen::VectorXd::Zero(5)}),
               Error);
  Eigen::VectorXd lost = frame;
  lost.tail(2).setConstant(NAN);  // every z sample lost
  EXPECT_THROW(EstimateDisplacementNoise({lost, lost, lost}), Error);
}

class RegularizationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = CalcSyntheticCompliance({.rows = 10, .cols = 10});
    spectrum_ = std::make_unique<ComplianceSpectrum>(model_.h);
  }

  // Loaded frames with noise, and their true forces.
  void MakeFrames(double sigma_mm, int count) {
    std::mt19937_64 rng(testing::kRandomSeed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    noise_.variance_mm2.setConstant(sigma_mm * sigma_mm);
    for (int k = 0; k < count; ++k) {
      const Eigen::VectorXd f = testing::MakeBumpLoad(
          model_.marker_positions, Eigen::Vector2d(3 * uniform(rng), 3 * uniform(rng)),
          3.0 + uniform(rng), Eigen::Vector3d(uniform(rng), uniform(rng), -3.0 + uniform(rng)));
      forces_.push_back(f);
      frames_.push_back(model_.h * f + GaussianNoise(f.size(), Eigen::Vector3d::Constant(sigma_mm),
                                                     &rng));
    }
  }

  // Mean squared force error over the frames at weight w.
  double ForceError(double w) const {
    double error = 0.0;
    for (size_t k = 0; k < frames_.size(); ++k) {
      error += (spectrum_->Solve(frames_[k], w) - forces_[k]).squaredNorm();
    }
    return error / frames_.size();
  }

  // The best error over a fine log grid of w: the oracle a rule is compared with.
  double BestForceError() const {
    const double s2 = std::pow(spectrum_->singular_values()(0), 2);
    double best = INFINITY;
    for (double e = -14; e <= 2; e += 0.05) best = std::min(best, ForceError(s2 * std::pow(10, e)));
    return best;
  }

  SyntheticCompliance model_;
  std::unique_ptr<ComplianceSpectrum> spectrum_;
  DisplacementNoise noise_;
  std::vector<Eigen::VectorXd> frames_, forces_;
};

TEST_F(RegularizationTest, SpectrumSolveIsTheTikhonovSolution) {
  MakeFrames(0.005, 1);
  const double w = 1e-3;
  const int n = model_.h.cols();
  const Eigen::MatrixXd normal =
      model_.h.transpose() * model_.h + w * Eigen::MatrixXd::Identity(n, n);
  const Eigen::VectorXd expected = normal.llt().solve(model_.h.transpose() * frames_[0]);
  EXPECT_THAT(spectrum_->Solve(frames_[0], w), EigenNear(expected, 1e-9 * expected.norm()));
  EXPECT_TRUE((spectrum_->singular_values().array() > 0).all());
}

TEST_F(RegularizationTest, DiscrepancyMeetsTheNoiseAndIsNearTheBestWeight) {
  MakeFrames(0.005, 8);
  const WeightSelection selection =
      SelectRegularizationWeight(*spectrum_, frames_, noise_, WeightSelectionOptions{});
  const WeightSelectionSummary& summary = selection.summary;
  EXPECT_TRUE(summary.converged) << summary.message;
  EXPECT_EQ(summary.num_frames, 8);
  EXPECT_NEAR(summary.target_residual_norm2_mm2, 100 * 3 * 0.005 * 0.005, 1e-15);
  EXPECT_NEAR(summary.residual_norm2_mm2 / summary.target_residual_norm2_mm2, 1.0, 1e-5);
  EXPECT_GT(summary.effective_parameters, 1.0);
  EXPECT_LT(summary.effective_parameters, 300.0);
  // The residual increases with w, so a larger w would exceed the noise.
  double residual = 0.0;
  for (const Eigen::VectorXd& d : frames_) {
    residual += (model_.h * spectrum_->Solve(d, 1.1 * selection.weight) - d).squaredNorm() / 8;
  }
  EXPECT_GT(residual, summary.target_residual_norm2_mm2);
  // Morozov's rule is known to over-smooth a little; within 1.5x of the oracle's error.
  EXPECT_LT(ForceError(selection.weight), 1.5 * BestForceError());
}

TEST_F(RegularizationTest, GcvEstimatesTheNoiseAndIsNearTheBestWeight) {
  // GCV needs a discrete ill-posed problem. The half-space H is well conditioned (cond ~ 50)
  // and GCV's minimum runs off to w -> 0 on it; H^3 (cond ~ 1e5, like the FEM's H) is not.
  model_.h = model_.h * model_.h * model_.h;
  spectrum_ = std::make_unique<ComplianceSpectrum>(model_.h);
  MakeFrames(0.005, 8);
  WeightSelectionOptions options;
  options.rule = WeightRule::kGeneralizedCrossValidation;
  const WeightSelection selection =
      SelectRegularizationWeight(*spectrum_, frames_, DisplacementNoise{}, options);
  EXPECT_TRUE(selection.summary.converged) << selection.summary.message;
  // 8 frames x 300 values: GCV's noise estimate within 10% of the truth.
  EXPECT_NEAR(selection.summary.implied_noise_variance_mm2 / (0.005 * 0.005), 1.0, 0.1);
  EXPECT_LT(ForceError(selection.weight), 1.5 * BestForceError());
}

TEST_F(RegularizationTest, DiscrepancyOnPureNoiseTakesTheLargestWeight) {
  MakeFrames(0.005, 2);
  // Unloaded frames whose noise (0.004 mm) is below the estimate (0.005 mm).
  std::mt19937_64 rng(testing::kRandomSeed + 1);
  for (Eigen::VectorXd& d : frames_) {
    d = GaussianNoise(d.size(), Eigen::Vector3d::Constant(0.004), &rng);
  }
  const WeightSelectionOptions options;
  const WeightSelection selection =
      SelectRegularizationWeight(*spectrum_, frames_, noise_, options);
  EXPECT_FALSE(selection.summary.converged);
  EXPECT_NEAR(selection.weight,
              options.max_relative_weight * std::pow(spectrum_->singular_values()(0), 2),
              1e-9 * selection.weight);
}

TEST_F(RegularizationTest, GivenWeightIsKept) {
  MakeFrames(0.005, 1);
  WeightSelectionOptions options;
  options.rule = WeightRule::kGiven;
  options.weight = 2.5e-3;
  const WeightSelection selection = SelectRegularizationWeight(*spectrum_, {}, noise_, options);
  EXPECT_EQ(selection.weight, 2.5e-3);
  EXPECT_EQ(ToJson(selection).at("rule"), "given");
}

TEST_F(RegularizationTest, BadInputThrows) {
  MakeFrames(0.005, 1);
  WeightSelectionOptions options;
  EXPECT_THROW(SelectRegularizationWeight(*spectrum_, {}, noise_, options), Error);
  EXPECT_THROW(SelectRegularizationWeight(*spectrum_, frames_, DisplacementNoise{}, options), Error);
  EXPECT_THROW(SelectRegularizationWeight(*spectrum_, {Eigen::VectorXd::Zero(5)}, noise_, options),
               Error);
  std::vector<Eigen::VectorXd> lost = frames_;
  lost[0](0) = NAN;
  EXPECT_THROW(SelectRegularizationWeight(*spectrum_, lost, noise_, options), Error);
  options.discrepancy_factor = 0.9;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.rule = WeightRule::kGiven;
  EXPECT_THROW(options.Validate(), Error);  // weight 0
  options = {};
  options.min_relative_weight = 0.0;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.max_relative_weight = options.min_relative_weight;
  EXPECT_THROW(options.Validate(), Error);
  EXPECT_THROW(ComplianceSpectrum(Eigen::MatrixXd::Zero(3, 6)), Error);
  Eigen::MatrixXd h = model_.h;
  h(1, 2) = INFINITY;
  EXPECT_THROW(ComplianceSpectrum{h}, Error);
}

TEST(WeightRule, NamesRoundTrip) {
  for (WeightRule rule : {WeightRule::kGiven, WeightRule::kDiscrepancy,
                          WeightRule::kGeneralizedCrossValidation}) {
    EXPECT_EQ(WeightRuleFromString(ToString(rule)), rule);
  }
  EXPECT_THROW(WeightRuleFromString("lcurve"), Error);
}

}  // namespace
}  // namespace tac3d
