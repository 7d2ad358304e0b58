#include "tac3d/force/force_reconstructor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <memory>
#include <random>
#include <thread>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "tac3d/force/regularization.h"
#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/force/test_loads.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

class ForceReconstructorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = CalcSyntheticCompliance({.rows = 12, .cols = 12});
    n_ = static_cast<int>(model_.marker_positions.size());
    s_max2_ = std::pow(ComplianceSpectrum(model_.h).singular_values()(0), 2);
    load_ = testing::MakeBumpLoad(model_.marker_positions, Eigen::Vector2d(0.7, -1.1), 3.5,
                                  Eigen::Vector3d(0.8, -0.5, -4.0));
    d_ = model_.h * load_;
  }

  // The paper's F = K D alone (the contact-support re-solve off).
  ForceReconstructor Make(double relative_weight, const Eigen::Vector3d& gains = {1, 1, 1}) const {
    return ForceReconstructor(
        model_.h, model_.marker_positions,
        {.weight = relative_weight * s_max2_, .gains = gains, .support_refinement = false});
  }

  // (H_v^T H_v + w I)^-1 H_v^T D_v in double precision, straight from its definition.
  Eigen::VectorXd RestrictedSolve(const std::vector<bool>& valid, double weight) const {
    std::vector<int> rows;
    for (int axis = 0; axis < 3; ++axis) {
      for (int i = 0; i < n_; ++i) {
        if (valid[i]) rows.push_back(axis * n_ + i);
      }
    }
    const Eigen::MatrixXd h_v = model_.h(rows, Eigen::all);
    const Eigen::VectorXd d_v = d_(rows);
    const Eigen::MatrixXd normal =
        h_v.transpose() * h_v + weight * Eigen::MatrixXd::Identity(3 * n_, 3 * n_);
    return normal.llt().solve(h_v.transpose() * d_v);
  }

  std::vector<bool> RandomMask(double invalid_fraction, std::uint64_t seed) const {
    std::mt19937_64 rng(seed);
    std::vector<int> order(n_);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    std::vector<bool> valid(n_, true);
    for (int k = 0; k < static_cast<int>(invalid_fraction * n_); ++k) valid[order[k]] = false;
    return valid;
  }

  SyntheticCompliance model_;
  int n_ = 0;
  double s_max2_ = 0.0;
  Eigen::VectorXd load_, d_;
};

TEST_F(ForceReconstructorTest, RecoversAKnownForceFromExactDisplacements) {
  ForceReconstructor reconstructor = Make(1e-10);
  const ForceFrame frame = reconstructor.Reconstruct(d_);
  EXPECT_EQ(frame.status, ForceStatus::kOk);
  EXPECT_EQ(frame.num_invalid_markers, 0);
  // Single-precision K: the error is rounding amplified by H's condition, far below 1e-3.
  EXPECT_LT((frame.forces_n - load_).norm(), 1e-3 * load_.norm());
  EXPECT_THAT(frame.resultant_force_n, EigenNear(Eigen::Vector3d(0.8, -0.5, -4.0), 1e-3));
}

TEST_F(ForceReconstructorTest, IsTheTikhonovSolution) {
  const double w = 1e-4 * s_max2_;
  ForceReconstructor reconstructor = Make(1e-4);
  const Eigen::VectorXd expected = ComplianceSpectrum(model_.h).Solve(d_, w);
  EXPECT_THAT(reconstructor.Reconstruct(d_).forces_n, EigenNear(expected, 1e-5 * expected.norm()));
  EXPECT_EQ(reconstructor.weight(), w);
}

TEST_F(ForceReconstructorTest, ResultantMomentAndGains) {
  ForceReconstructor unit = Make(1e-4);
  const Eigen::Vector3d gains(1.2, 0.9, 1.05);
  ForceReconstructor gained = Make(1e-4, gains);
  const ForceFrame a = unit.Reconstruct(d_);
  const ForceFrame b = gained.Reconstruct(d_);
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
  for (int i = 0; i < n_; ++i) {
    const Eigen::Vector3d f = gains.cwiseProduct(a.MarkerForce(i));
    EXPECT_THAT(b.MarkerForce(i), EigenNear(f, 1e-12));
    const Eigen::Vector3d p =
        model_.marker_positions[i] + Eigen::Vector3d(d_(i), d_(n_ + i), d_(2 * n_ + i));
    force += f;
    moment += p.cross(f);
  }
  EXPECT_THAT(b.resultant_force_n, EigenNear(force, 1e-12));
  EXPECT_THAT(b.resultant_moment_nmm, EigenNear(moment, 1e-11));
  // A pure normal load off the axis has a moment about x and y, none about z.
  EXPECT_GT(std::abs(b.resultant_moment_nmm.x()), 1.0);
  unit.set_gains(gains);
  EXPECT_THAT(unit.Reconstruct(d_).forces_n, EigenNear(b.forces_n, 1e-12));
}

TEST_F(ForceReconstructorTest, InvalidMarkersSolveTheRestrictedProblemExactly) {
  const double relative_weight = 1e-5;
  ForceReconstructor reconstructor = Make(relative_weight);
  const std::vector<bool> mask_a = RandomMask(0.1, 1), mask_b = RandomMask(0.25, 2);
  ForceFrame frame;
  // A, then B, then A again: the cached factor follows the mask.
  for (const auto* mask : {&mask_a, &mask_b, &mask_a}) {
    reconstructor.Reconstruct(d_, *mask, &frame);
    const Eigen::VectorXd expected = RestrictedSolve(*mask, relative_weight * s_max2_);
    EXPECT_EQ(frame.status, ForceStatus::kOk);
    // Only the final K D~ is single precision (the lost rows' prediction is solved in double):
    // 1e-5 (5e-7 measured), where ignoring the invalid rows' coupling would be off by tens of
    // percent.
    EXPECT_THAT(frame.forces_n, EigenNear(expected, 1e-5 * expected.norm()));
  }
  // A NaN component invalidates its marker just as the flag does.
  Eigen::VectorXd d_lost = d_;
  std::vector<bool> all_valid(n_, true);
  for (int i = 0; i < n_; ++i) {
    if (!mask_a[i]) d_lost(2 * n_ + i) = NAN;
  }
  const ForceFrame lost = reconstructor.Reconstruct(d_lost, all_valid);
  EXPECT_EQ(lost.num_invalid_markers, static_cast<int>(0.1 * n_));
  EXPECT_THAT(lost.forces_n, EigenNear(frame.forces_n, 1e-12));
}

// Masks as a tracker produces them, one after the other through the same reconstructor: a few
// markers flickering, a speck of 3 x 3 markers crossing the grid, masks drawn afresh (most
// markers differ), more markers lost than ever before, none lost. Each frame must solve its own
// restricted problem, whatever the cache held.
TEST_F(ForceReconstructorTest, ChangingMasksEachSolveTheirRestrictedProblem) {
  const double relative_weight = 1e-5;
  ForceReconstructor reconstructor = Make(relative_weight);
  std::mt19937_64 rng(testing::kRandomSeed);
  std::vector<std::vector<bool>> masks;
  std::vector<bool> mask = RandomMask(0.1, 11);
  for (int flips : {1, 1, 2, 5, 20, 60}) {
    for (int k = 0; k < flips; ++k) {
      const int i = static_cast<int>(rng() % n_);
      mask[i] = !mask[i];
    }
    masks.push_back(mask);
  }
  for (int col = 0; col + 3 <= 12; ++col) {
    std::vector<bool> speck(n_, true);
    for (int row = 4; row < 7; ++row) {
      for (int c = col; c < col + 3; ++c) speck[row * 12 + c] = false;
    }
    masks.push_back(speck);
  }
  for (std::uint64_t seed : {12, 13, 14}) masks.push_back(RandomMask(0.1, seed));
  masks.push_back(RandomMask(0.5, 15));
  masks.push_back(std::vector<bool>(n_, true));
  masks.push_back(RandomMask(0.02, 16));
  masks.push_back(masks.front());
  ForceFrame frame;
  double worst_relative_error = 0.0, worst_uncoupled_error = std::numeric_limits<double>::max();
  for (size_t k = 0; k < masks.size(); ++k) {
    reconstructor.Reconstruct(d_, masks[k], &frame);
    const Eigen::VectorXd expected = RestrictedSolve(masks[k], relative_weight * s_max2_);
    ASSERT_EQ(frame.status, ForceStatus::kOk) << k;
    const double error = (frame.forces_n - expected).cwiseAbs().maxCoeff() / expected.norm();
    worst_relative_error = std::max(worst_relative_error, error);
    // The answer that ignores the lost rows' coupling (K D with them zeroed), for scale.
    if (frame.num_invalid_markers > 0) {
      Eigen::VectorXd d_zeroed = d_;
      for (int i = 0; i < n_; ++i) {
        if (!masks[k][i]) d_zeroed(i) = d_zeroed(n_ + i) = d_zeroed(2 * n_ + i) = 0.0;
      }
      const Eigen::VectorXd uncoupled = reconstructor.k().cast<double>() * d_zeroed;
      worst_uncoupled_error = std::min(
          worst_uncoupled_error, (uncoupled - expected).cwiseAbs().maxCoeff() / expected.norm());
    }
    // Single-precision K D: the all-valid frames' error is ~1e-7.
    EXPECT_THAT(frame.forces_n, EigenNear(expected, 1e-5 * expected.norm())) << k;
  }
  std::printf("%zu masks: largest error %.2e of |F|; ignoring the coupling: at least %.2e\n",
              masks.size(), worst_relative_error, worst_uncoupled_error);
  EXPECT_GT(worst_uncoupled_error, 1e3 * worst_relative_error);
}

// With the re-solve on, a reconstructor that has seen other masks and supports gives what a
// fresh one gives: each mask twice in a row, the second time with slightly different data (the
// same support, so the cached support factor is reused), then another mask.
TEST_F(ForceReconstructorTest, ChangingMasksWithTheSupportMatchAFreshReconstructor) {
  const Eigen::VectorXd press = testing::MakeBumpLoad(
      model_.marker_positions, Eigen::Vector2d(0.4, -0.3), 1.2, Eigen::Vector3d(0.6, -0.4, -3.0));
  const Eigen::VectorXd d = model_.h * press;
  std::mt19937_64 rng(testing::kRandomSeed);
  std::normal_distribution<double> normal(0.0, 1e-5);
  Eigen::VectorXd d_noisy = d;
  for (Eigen::Index j = 0; j < d.size(); ++j) d_noisy(j) += normal(rng);
  const ForceReconstructorOptions options{.weight = 1e-4 * s_max2_};
  ForceReconstructor reused(model_.h, model_.marker_positions, options);
  ForceFrame frame;
  int refined = 0;
  for (std::uint64_t seed : {21, 22, 23}) {
    for (double fraction : {0.05, 0.1, 0.0}) {
      const std::vector<bool> valid = RandomMask(fraction, seed);
      ForceReconstructor fresh(model_.h, model_.marker_positions, options);
      Eigen::ArrayX<bool> first_support;
      for (const Eigen::VectorXd* data : {&d, &std::as_const(d_noisy)}) {
        reused.Reconstruct(*data, valid, &frame);
        const ForceFrame expected = fresh.Reconstruct(*data, valid);
        EXPECT_EQ(frame.support_refined, expected.support_refined);
        EXPECT_EQ(frame.num_support_markers, expected.num_support_markers);
        EXPECT_THAT(frame.forces_n,
                    EigenNear(expected.forces_n, 1e-12 * expected.forces_n.norm()))
            << seed << " " << fraction;
        refined += frame.support_refined;
        // The second frame's support is the first's (the premise of the reuse).
        const Eigen::ArrayX<bool> support = frame.forces_n.array() != 0.0;
        if (data == &d) {
          first_support = support;
        } else {
          EXPECT_TRUE((support == first_support).all()) << seed << " " << fraction;
        }
      }
    }
  }
  EXPECT_GT(refined, 12);
}

// w far below double precision's reach for the markers lost: I - M_RR is rounding noise about
// zero, so its factorisation fails; the frame says so and keeps K D with the lost rows zeroed,
// for as long as the mask stays (the failure is cached with the factor).
TEST_F(ForceReconstructorTest, AWeightTooSmallForTheLostMarkersIsReported) {
  ForceReconstructor reconstructor = Make(1e-18);
  const std::vector<bool> valid = RandomMask(0.1, 31);
  Eigen::VectorXd d_zeroed = d_;
  for (int i = 0; i < n_; ++i) {
    if (!valid[i]) d_zeroed(i) = d_zeroed(n_ + i) = d_zeroed(2 * n_ + i) = 0.0;
  }
  const Eigen::VectorXd k_d0 = reconstructor.k().cast<double>() * d_zeroed;
  ForceFrame frame;
  for (int k = 0; k < 2; ++k) {
    reconstructor.Reconstruct(d_, valid, &frame);
    EXPECT_EQ(frame.status, ForceStatus::kRestrictedProblemIllConditioned);
    EXPECT_THAT(frame.forces_n, EigenNear(k_d0, 1e-6 * k_d0.norm()));
  }
  // With every marker valid the problem is the well-posed full one again.
  EXPECT_EQ(reconstructor.Reconstruct(d_).status, ForceStatus::kOk);
}

TEST_F(ForceReconstructorTest, TenPercentInvalidStaysCloseOnASmoothLoad) {
  // With the weight the discrepancy principle picks for 0.005 mm of noise.
  std::mt19937_64 rng(testing::kRandomSeed);
  std::normal_distribution<double> normal(0.0, 0.005);
  Eigen::VectorXd d = d_;
  for (int j = 0; j < d.size(); ++j) d(j) += normal(rng);
  DisplacementNoise noise;
  noise.variance_mm2.setConstant(0.005 * 0.005);
  const WeightSelection selection = SelectRegularizationWeight(
      ComplianceSpectrum(model_.h), {d}, noise, WeightSelectionOptions{});
  ASSERT_TRUE(selection.summary.converged);
  ForceReconstructor reconstructor(model_.h, model_.marker_positions,
                                   {.weight = selection.weight, .support_refinement = false});
  const ForceFrame full = reconstructor.Reconstruct(d);
  for (std::uint64_t seed : {1, 2, 3}) {
    const ForceFrame partial = reconstructor.Reconstruct(d, RandomMask(0.1, seed));
    EXPECT_TRUE(partial.forces_n.allFinite());
    EXPECT_EQ(partial.num_invalid_markers, static_cast<int>(0.1 * n_));
    // Losing 10% of the data costs accuracy, but not much more than the noise already does.
    EXPECT_LT((partial.forces_n - load_).norm(), 1.5 * (full.forces_n - load_).norm()) << seed;
    EXPECT_LT((partial.resultant_force_n - full.resultant_force_n).norm(),
              0.05 * full.resultant_force_n.norm())
        << seed;
  }
}

TEST_F(ForceReconstructorTest, NoValidMarkerGivesZeroForcesAndAStatus) {
  ForceReconstructor reconstructor = Make(1e-4);
  const ForceFrame frame = reconstructor.Reconstruct(d_, std::vector<bool>(n_, false));
  EXPECT_EQ(frame.status, ForceStatus::kNoValidMarkers);
  EXPECT_EQ(frame.num_invalid_markers, n_);
  EXPECT_EQ(frame.forces_n, Eigen::VectorXd::Zero(3 * n_));
  EXPECT_EQ(frame.resultant_force_n, Eigen::Vector3d::Zero());
}

TEST_F(ForceReconstructorTest, UncertaintyMatchesMonteCarlo) {
  const Eigen::Vector3d sigma(0.004, 0.005, 0.008);
  const Eigen::Vector3d gains(1.1, 0.9, 1.3);
  ForceReconstructor reconstructor = Make(1e-5, gains);
  const ForceUncertainty predicted = reconstructor.CalcUncertainty(sigma.cwiseAbs2());
  constexpr int kSamples = 4000;
  std::mt19937_64 rng(testing::kRandomSeed);
  std::normal_distribution<double> normal;
  Eigen::ArrayXd sum_squares = Eigen::ArrayXd::Zero(3 * n_);
  Eigen::Array3d resultant_squares = Eigen::Array3d::Zero();
  ForceFrame frame;
  Eigen::VectorXd e(3 * n_);
  for (int k = 0; k < kSamples; ++k) {
    for (int j = 0; j < 3 * n_; ++j) e(j) = sigma(j / n_) * normal(rng);
    reconstructor.Reconstruct(e, {}, &frame);
    sum_squares += frame.forces_n.array().square();
    resultant_squares += frame.resultant_force_n.array().square();
  }
  const Eigen::ArrayXd sampled = (sum_squares / kSamples).sqrt();
  // 4000 samples: a sampled sigma's relative standard deviation is 1/sqrt(8000) = 1.1%.
  Eigen::ArrayXd ratio(3 * n_);
  for (int j = 0; j < 3 * n_; ++j) ratio(j) = sampled(j) / predicted.marker_sigma_n(j / n_, j % n_);
  EXPECT_LT((ratio - 1.0).abs().maxCoeff(), 0.05);
  EXPECT_LT(std::abs(ratio.mean() - 1.0), 0.01);
  // The resultant's moment arms do not enter; only the noise of D moves it (markers at rest).
  const Eigen::Array3d resultant = (resultant_squares / kSamples).sqrt();
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(resultant(axis) / predicted.resultant_sigma_n(axis), 1.0, 0.05) << axis;
  }
}

// A compact press: the re-solve on the contact support keeps the resultant's scale and cuts its
// noise, where F = K D shrinks it (Tikhonov) and spreads noise over every marker.
TEST_F(ForceReconstructorTest, SupportRefinementRecoversACompactPress) {
  const Eigen::VectorXd press = testing::MakeBumpLoad(
      model_.marker_positions, Eigen::Vector2d(0.4, -0.3), 1.2, Eigen::Vector3d(0.6, -0.4, -3.0));
  const Eigen::Vector3d truth(0.6, -0.4, -3.0);
  const double weight = 1e-4 * s_max2_;
  ForceReconstructor refined(model_.h, model_.marker_positions, {.weight = weight});
  // Exact data: the true support lies inside S, so the re-solve recovers the load.
  const Eigen::VectorXd d = model_.h * press;
  const ForceFrame exact = refined.Reconstruct(d);
  ASSERT_TRUE(exact.support_refined);
  EXPECT_GT(exact.num_support_markers, 0);
  EXPECT_LT(exact.num_support_markers, n_ / 2);
  EXPECT_LT((exact.resultant_force_n - truth).norm(), 1e-3 * truth.norm());
  EXPECT_LT((exact.forces_n - press).norm(), 0.02 * press.norm());
  // Outside the support the forces are zero.
  int zero_markers = 0;
  for (int i = 0; i < n_; ++i) zero_markers += exact.MarkerForce(i).isZero(0.0);
  EXPECT_EQ(zero_markers, n_ - exact.num_support_markers);
  // Noisy data, w as large as the discrepancy principle takes it for this noise: F = K D shrinks
  // the resultant, the refined one keeps it (RMS error well under the paper's).
  ForceReconstructor paper_smooth(model_.h, model_.marker_positions,
                                  {.weight = 1e-2 * s_max2_, .support_refinement = false});
  ForceReconstructor refined_smooth(model_.h, model_.marker_positions, {.weight = 1e-2 * s_max2_});
  std::mt19937_64 rng(testing::kRandomSeed);
  std::normal_distribution<double> normal(0.0, 0.005);
  double paper_sq = 0.0, refined_sq = 0.0;
  constexpr int kFrames = 100;
  for (int k = 0; k < kFrames; ++k) {
    Eigen::VectorXd noisy = d;
    for (Eigen::Index j = 0; j < noisy.size(); ++j) noisy(j) += normal(rng);
    paper_sq += (paper_smooth.Reconstruct(noisy).resultant_force_n - truth).squaredNorm();
    refined_sq += (refined_smooth.Reconstruct(noisy).resultant_force_n - truth).squaredNorm();
  }
  std::printf("resultant RMS error over %d noisy frames: F = K D %.4f N, refined %.4f N\n", kFrames,
              std::sqrt(paper_sq / kFrames), std::sqrt(refined_sq / kFrames));
  EXPECT_LT(std::sqrt(refined_sq / kFrames), 0.5 * std::sqrt(paper_sq / kFrames));
}

TEST_F(ForceReconstructorTest, SupportRefinementWithLostMarkersSolvesTheValidRows) {
  const Eigen::VectorXd press = testing::MakeBumpLoad(
      model_.marker_positions, Eigen::Vector2d(0.4, -0.3), 1.2, Eigen::Vector3d(0.6, -0.4, -3.0));
  const Eigen::VectorXd d = model_.h * press;
  const double weight = 1e-4 * s_max2_;
  ForceReconstructor refined(model_.h, model_.marker_positions, {.weight = weight});
  const std::vector<bool> valid = RandomMask(0.1, 7);
  const ForceFrame frame = refined.Reconstruct(d, valid);
  ASSERT_TRUE(frame.support_refined);
  // The same problem straight from its definition: valid rows, the frame's support columns.
  std::vector<int> rows, columns;
  for (int axis = 0; axis < 3; ++axis) {
    for (int i = 0; i < n_; ++i) {
      if (valid[i]) rows.push_back(axis * n_ + i);
      if (!frame.MarkerForce(i).isZero(0.0)) columns.push_back(axis * n_ + i);
    }
  }
  ASSERT_EQ(static_cast<int>(columns.size()), 3 * frame.num_support_markers);
  const Eigen::MatrixXd h_vs = model_.h(rows, columns);
  const Eigen::MatrixXd normal =
      h_vs.transpose() * h_vs +
      ForceReconstructorOptions{}.support_weight * Eigen::MatrixXd::Identity(columns.size(), columns.size());
  const Eigen::VectorXd expected = normal.llt().solve(h_vs.transpose() * d(rows));
  EXPECT_LT((frame.forces_n(columns) - expected).norm(), 1e-9 * expected.norm());
  EXPECT_TRUE(frame.forces_n.allFinite());
}

TEST_F(ForceReconstructorTest, ASupportOverTheLimitKeepsTheTikhonovForces) {
  const double weight = 1e-4 * s_max2_;
  ForceReconstructor paper(model_.h, model_.marker_positions,
                           {.weight = weight, .support_refinement = false});
  ForceReconstructor capped(model_.h, model_.marker_positions,
                            {.weight = weight, .max_support_markers = 4});
  // load_ is a broad bump: its support has far more than 4 markers.
  const ForceFrame frame = capped.Reconstruct(d_);
  EXPECT_FALSE(frame.support_refined);
  EXPECT_EQ(frame.num_support_markers, 0);
  EXPECT_EQ(frame.forces_n, paper.Reconstruct(d_).forces_n);
  // No load: nothing to refine, forces are K D.
  const ForceFrame rest = capped.Reconstruct(Eigen::VectorXd::Zero(3 * n_));
  EXPECT_FALSE(rest.support_refined);
  EXPECT_TRUE(rest.forces_n.isZero(0.0));
}

TEST_F(ForceReconstructorTest, BadInputThrows) {
  EXPECT_THROW(Make(0.0), Error);
  const auto make = [&](ForceReconstructorOptions options) {
    options.weight = 1.0;
    return ForceReconstructor(model_.h, model_.marker_positions, options);
  };
  EXPECT_THROW(make({.support_threshold_n = -0.1}), Error);
  EXPECT_THROW(make({.support_margin_pitches = -1.0}), Error);
  EXPECT_THROW(make({.support_weight = 0.0}), Error);
  EXPECT_THROW(make({.max_support_markers = 0}), Error);
  // Issue 14, defect 7: w = 1e300 made every force exactly 0.
  EXPECT_THAT([&] { Make(1e300); }, ::testing::ThrowsMessage<Error>(::testing::HasSubstr("the regularisation would drive every force to ~0")));
  EXPECT_THROW(Make(1e-4, Eigen::Vector3d(1, 0, 1)), Error);
  EXPECT_THROW(Make(1e-4, Eigen::Vector3d(1, 1, NAN)), Error);
  EXPECT_THROW(ForceReconstructor(model_.h.topRows(6), model_.marker_positions, {.weight = 1.0}),
               Error);
  std::vector<Eigen::Vector3d> too_few = model_.marker_positions;
  too_few.pop_back();
  EXPECT_THROW(ForceReconstructor(model_.h, too_few, {.weight = 1.0}), Error);
  Eigen::MatrixXd h = model_.h;
  h(0, 0) = NAN;
  EXPECT_THROW(ForceReconstructor(h, model_.marker_positions, {.weight = 1.0}), Error);
  // A rank-one H with a weight below double precision's reach: rounding leaves pivots <= 0.
  EXPECT_THROW(ForceReconstructor(Eigen::MatrixXd::Constant(3 * n_, 3 * n_, 0.1),
                                  model_.marker_positions,
                                  {.weight = 1e-300}),
               Error);
  EXPECT_THROW(ForceReconstructor(std::shared_ptr<const Eigen::MatrixXd>(), model_.marker_positions, {.weight = 1.0}),
               Error);
  EXPECT_THROW(TikhonovInverse(std::make_shared<const Eigen::MatrixXd>(model_.h.topRows(6)), 1.0), Error);
  EXPECT_THROW(SharedTikhonovInverse(std::make_shared<const Eigen::MatrixXd>(model_.h), NAN), Error);
  ForceReconstructor reconstructor = Make(1e-4);
  EXPECT_THROW(reconstructor.Reconstruct(Eigen::VectorXd::Zero(5)), Error);
  EXPECT_THROW(reconstructor.Reconstruct(d_, std::vector<bool>(3, true)), Error);
  EXPECT_THROW(reconstructor.CalcUncertainty(Eigen::Vector3d(1e-6, -1e-6, 1e-6)), Error);
  EXPECT_THROW(reconstructor.set_gains(Eigen::Vector3d(-1, 1, 1)), Error);
  // Issue 22, defect 11: `--gains 1e300` was accepted.
  EXPECT_THAT([&] { reconstructor.set_gains(Eigen::Vector3d(1, 1e300, 1)); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "ForceReconstructor::set_gains.gains.y must be in (0, 1000], got 1e+300")));
  EXPECT_NO_THROW(reconstructor.set_gains(Eigen::Vector3d(1, kMaxForceGain, 1)));
}

// The sensors of one model: reconstructors of one H object and weight hold one copy of K, M and
// H^T H, and H itself is not copied; another weight or another H object gets its own. Each keeps
// its own per-frame state (its lost markers, its support), and gives what an unshared one gives.
TEST_F(ForceReconstructorTest, ReconstructorsOfOneHAndWeightShareOneInverse) {
  const auto h = std::make_shared<const Eigen::MatrixXd>(model_.h);
  const ForceReconstructorOptions options{.weight = 1e-4 * s_max2_};
  ForceReconstructor a(h, model_.marker_positions, options);
  ForceReconstructor b(h, model_.marker_positions, options);
  EXPECT_EQ(a.inverse(), b.inverse());
  EXPECT_EQ(&a.inverse()->h(), h.get());
  ForceReconstructorOptions heavier = options;
  heavier.weight *= 2.0;
  EXPECT_NE(ForceReconstructor(h, model_.marker_positions, heavier).inverse(), a.inverse());
  ForceReconstructor unshared(model_.h, model_.marker_positions, options);  // a copy of H
  EXPECT_NE(unshared.inverse(), a.inverse());
  EXPECT_NE(&unshared.inverse()->h(), h.get());

  const std::vector<bool> mask = RandomMask(0.1, testing::kRandomSeed);
  const ForceFrame lost = a.Reconstruct(d_, mask);
  const ForceFrame all = b.Reconstruct(d_);
  EXPECT_EQ(lost.num_invalid_markers, static_cast<int>(0.1 * n_));
  EXPECT_EQ(all.num_invalid_markers, 0);
  EXPECT_THAT(lost.forces_n, EigenNear(unshared.Reconstruct(d_, mask).forces_n, 1e-12));
  EXPECT_THAT(all.forces_n, EigenNear(unshared.Reconstruct(d_).forces_n, 1e-12));
  EXPECT_THAT(a.Reconstruct(d_, mask).forces_n, EigenNear(lost.forces_n, 1e-12));
}

TEST_F(ForceReconstructorTest, TheSharedInverseIsFreedWithItsLastReconstructor) {
  const auto h = std::make_shared<const Eigen::MatrixXd>(model_.h);
  std::weak_ptr<const TikhonovInverse> inverse;
  {
    const ForceReconstructor a(h, model_.marker_positions, {.weight = 1e-4 * s_max2_});
    inverse = a.inverse();
    const ForceReconstructor b(h, model_.marker_positions, {.weight = 1e-4 * s_max2_});
  }
  EXPECT_TRUE(inverse.expired());
}

// Two sensors of one model opened on two threads at once get one inverse (util/shared_cache_test
// checks that the second waits for the first's).
TEST_F(ForceReconstructorTest, ReconstructorsMadeOnTwoThreadsAtOnceShareOneInverse) {
  const auto h = std::make_shared<const Eigen::MatrixXd>(model_.h);
  const ForceReconstructorOptions options{.weight = 1e-4 * s_max2_};
  std::shared_ptr<const TikhonovInverse> first;
  std::thread other([&] { first = ForceReconstructor(h, model_.marker_positions, options).inverse(); });
  const std::shared_ptr<const TikhonovInverse> second =
      ForceReconstructor(h, model_.marker_positions, options).inverse();
  other.join();
  EXPECT_EQ(first, second);
}

}  // namespace
}  // namespace tac3d
