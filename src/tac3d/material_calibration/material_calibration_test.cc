#include "tac3d/material_calibration/material_calibration.h"

#include <gtest/gtest.h>

#include <random>

#include "tac3d/fem/compliance.h"
#include "tac3d/fem/compliance_family.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

// A test-size dome: 6 x 6 markers, so a press covers several of them.
fem::BodyModelOptions SmallDome(const ElasticMaterial& material) {
  fem::BodyModelOptions options;
  options.base_diameter_mm = 16.0;
  options.thickness_mm = 4.0;
  options.sphere_radius_mm = 30.0;
  options.marker_rows = 6;
  options.marker_cols = 6;
  options.material = material;
  return options;
}

const std::vector<double> kNodes = {0.40, 0.45, 0.48, 0.499};
constexpr double kNoiseMm = 0.002;

class MaterialCalibrationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    family_ = new fem::ComplianceFamily(SmallDome({1.0, 0.48}), kNodes, "");
    truth_ = new fem::ComplianceModel(fem::CalcComplianceModel(SmallDome(kTrueMaterial)));
  }
  static void TearDownTestSuite() {
    delete family_;
    delete truth_;
  }

  // Presses on the true sensor, D = H_true F + noise: Hertz-like marker forces over a disc of
  // radius 1.3-2.5 mm, Fz 1-10 N, tangential force up to tangential_ratio Fz in x and y.
  static std::vector<CalibrationPress> SimulatePresses(int count, double tangential_ratio) {
    std::mt19937_64 rng(testing::kRandomSeed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::normal_distribution<double> noise(0.0, kNoiseMm);
    const std::vector<Eigen::Vector3d>& markers = truth_->marker_positions;
    const int n = static_cast<int>(markers.size());
    std::vector<CalibrationPress> presses;
    for (int k = 0; k < count; ++k) {
      const Eigen::Vector2d center(3 * uniform(rng) - 1.5, 3 * uniform(rng) - 1.5);
      const double radius = 1.3 + 1.2 * uniform(rng);
      const double fz = 1.0 + 9.0 * uniform(rng);
      const Eigen::Vector3d force(tangential_ratio * fz * (2 * uniform(rng) - 1),
                                  tangential_ratio * fz * (2 * uniform(rng) - 1),
                                  -fz);
      Eigen::VectorXd weights = Eigen::VectorXd::Zero(n);
      for (int i = 0; i < n; ++i) {
        const double r2 = (markers[i].head<2>() - center).squaredNorm() / (radius * radius);
        if (r2 < 1.0) weights(i) = std::sqrt(1.0 - r2);
      }
      Eigen::VectorXd f(3 * n);
      for (int axis = 0; axis < 3; ++axis)
        f.segment(axis * n, n) = force(axis) / weights.sum() * weights;
      CalibrationPress press{truth_->h * f, force, center};
      for (Eigen::Index j = 0; j < press.displacement_mm.size(); ++j)
        press.displacement_mm(j) += noise(rng);
      presses.push_back(press);
    }
    return presses;
  }

  static DisplacementNoise Noise() {
    DisplacementNoise noise;
    noise.variance_mm2.setConstant(kNoiseMm * kNoiseMm);
    return noise;
  }

  // Between two nodes, so the interpolation is exercised; E off nominal.
  static constexpr ElasticMaterial kTrueMaterial{1.3, 0.465};
  static fem::ComplianceFamily* family_;
  static fem::ComplianceModel* truth_;
};

fem::ComplianceFamily* MaterialCalibrationTest::family_ = nullptr;
fem::ComplianceModel* MaterialCalibrationTest::truth_ = nullptr;

TEST_F(MaterialCalibrationTest, RecoversAKnownMaterialFromMixedPresses) {
  const MaterialCalibrationOptions options;
  const MaterialCalibration fit =
      CalibrateMaterial(*family_, SimulatePresses(24, 0.6), Noise(), options);
  std::printf("%s; sensitivity %.3g per unit nu, residual %.4f N\n",
              fit.message.c_str(),
              fit.poisson_sensitivity,
              fit.residual_rms_n);
  // nu within the accepted error bound (0.005) and within its own bound.
  EXPECT_NEAR(fit.material.poisson_ratio, kTrueMaterial.poisson_ratio, options.max_poisson_error);
  EXPECT_LE(std::abs(fit.material.poisson_ratio - kTrueMaterial.poisson_ratio),
            fit.poisson_error_bound);
  EXPECT_NEAR(fit.material.youngs_modulus_mpa / kTrueMaterial.youngs_modulus_mpa, 1.0, 0.02);
  EXPECT_FALSE(fit.at_range_limit);
  // The truth is this FEM: nothing is left for the gains.
  for (int axis = 0; axis < 3; ++axis) EXPECT_NEAR(fit.gains.gains(axis), 1.0, 0.02) << axis;
}

// Presses with their centres: the centres are fitted beside the resultants (on this dome they
// add little about nu: the inverse's centroid hardly moves with it, docs/force.md) and their
// residual reports a probe that is not where the press file says, here 2 mm off in x: it
// widens nu's bound past the default and the refusal says so.
TEST_F(MaterialCalibrationTest, ContactCentresAreFittedAndReportAMisplacedProbe) {
  std::vector<CalibrationPress> presses = SimulatePresses(24, 0.6);
  const MaterialCalibration located = CalibrateMaterial(*family_, presses, Noise(), {});
  EXPECT_EQ(located.num_located_presses, 24);
  EXPECT_GT(located.location_residual_rms_mm, 0.0);
  EXPECT_LT(located.location_residual_rms_mm, 0.2);
  EXPECT_NEAR(located.material.poisson_ratio, kTrueMaterial.poisson_ratio,
              located.poisson_error_bound);
  for (CalibrationPress& press : presses) *press.contact_center_mm += Eigen::Vector2d(2.0, 0.0);
  try {
    CalibrateMaterial(*family_, presses, Noise(), {});
    FAIL() << "centres 2 mm off were accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("The 24 contact centres are 2"));
  }
  MaterialCalibrationOptions lenient;
  lenient.max_poisson_error = 0.01;
  EXPECT_NEAR(CalibrateMaterial(*family_, presses, Noise(), lenient).location_residual_rms_mm, 2.0,
              0.2);
  for (CalibrationPress& press : presses) press.contact_center_mm.reset();
  EXPECT_EQ(CalibrateMaterial(*family_, presses, Noise(), {}).num_located_presses, 0);
}

TEST_F(MaterialCalibrationTest, RefusesNormalOnlyPressesForPoissonsRatio) {
  std::vector<CalibrationPress> presses = SimulatePresses(24, 0.0);
  for (CalibrationPress& press : presses) press.contact_center_mm.reset();
  try {
    CalibrateMaterial(*family_, presses, Noise(), {});
    FAIL() << "normal presses were accepted";
  } catch (const Error& e) {
    std::printf("%s\n", e.what());
    EXPECT_THAT(e.what(), HasSubstr("cannot determine Poisson's ratio"));
  }
}

TEST(MaterialCalibrationOptions, ValidateNamesTheField) {
  MaterialCalibrationOptions options;
  EXPECT_NO_THROW(options.Validate());
  options.poisson_tolerance = 0.0;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.max_poisson_error = 0.0;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.model_relative_error = -1.0;
  EXPECT_THROW(options.Validate(), Error);
}

}  // namespace
}  // namespace tac3d
