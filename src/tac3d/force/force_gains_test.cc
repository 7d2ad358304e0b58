#include "tac3d/force/force_gains.h"

#include <fstream>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

std::vector<ForcePair> RandomPairs(const Eigen::Vector3d& gains, double noise_n, int count) {
  std::mt19937_64 rng(testing::kRandomSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> normal(0.0, noise_n);
  std::vector<ForcePair> pairs(count);
  for (ForcePair& pair : pairs) {
    pair.reference_n = Eigen::Vector3d(5 * uniform(rng), 5 * uniform(rng), -5 + 5 * uniform(rng));
    for (int axis = 0; axis < 3; ++axis) {
      pair.measured_n(axis) = (pair.reference_n(axis) + normal(rng)) / gains(axis);
    }
  }
  return pairs;
}

TEST(FitForceGains, ExactOnNoiseFreePairs) {
  const Eigen::Vector3d gains(1.12, 0.87, 1.31);
  const ForceGainFit fit = FitForceGains(RandomPairs(gains, 0.0, 20));
  EXPECT_THAT(fit.gains, EigenNear(gains, 1e-14));
  EXPECT_THAT(fit.r_squared, EigenNear(Eigen::Vector3d::Ones(), 1e-14));
  EXPECT_THAT(fit.residual_rms_n, EigenNear(Eigen::Vector3d::Zero(), 1e-13));
  EXPECT_EQ(fit.num_pairs, 20);
  EXPECT_EQ(ToJson(fit).at("gains").size(), 3u);
}

TEST(FitForceGains, ResidualIsTheReferenceNoise) {
  const Eigen::Vector3d gains(1.12, 0.87, 1.31);
  const ForceGainFit fit = FitForceGains(RandomPairs(gains, 0.05, 2000));
  // Noise on the measured side: the slope is biased by var(noise)/var(ref) ~ 3e-4, below this.
  EXPECT_THAT(fit.gains, EigenNear(gains, 0.005));
  for (int axis = 0; axis < 3; ++axis) {
    // 2000 residuals: the RMS's relative standard deviation is 1.6%.
    EXPECT_NEAR(fit.residual_rms_n(axis) / 0.05, 1.0, 0.06) << axis;
    EXPECT_GT(fit.r_squared(axis), 0.99);
    EXPECT_LT(fit.r_squared(axis), 1.0);
  }
}

TEST(FitForceGains, UnexcitedOrReversedAxisThrows) {
  std::vector<ForcePair> pairs = RandomPairs(Eigen::Vector3d::Ones(), 0.0, 5);
  EXPECT_THROW(FitForceGains({}), Error);
  std::vector<ForcePair> no_y = pairs;
  for (ForcePair& pair : no_y) pair.measured_n.y() = 0.0;
  EXPECT_THROW(FitForceGains(no_y), Error);
  std::vector<ForcePair> reversed = pairs;
  for (ForcePair& pair : reversed) pair.measured_n.x() *= -1.0;
  EXPECT_THROW(FitForceGains(reversed), Error);
}

// Issue 14, defect 7: one pair was accepted and reported R^2 = 1.
TEST(FitForceGains, TooFewPairsAreRefused) {
  const std::vector<ForcePair> pairs = RandomPairs(Eigen::Vector3d::Ones(), 0.0, kMinForcePairs);
  EXPECT_NO_THROW(FitForceGains(pairs));
  EXPECT_THAT([&] { FitForceGains({pairs.front()}); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("1 force pair(s); the fit needs at least 3")));
}

// Pairs whose x and y references are noise unrelated to the measured forces (a calibration
// of normal presses only: the tangential forces are noise on both sides), z a good fit. Each
// noise axis' measured values are turned to agree with the reference in sign on the whole, so
// the gain is positive and it is R^2 that must refuse it.
std::vector<ForcePair> NoiseInXAndY(int count) {
  std::vector<ForcePair> pairs = RandomPairs(Eigen::Vector3d::Ones(), 0.01, count);
  std::mt19937_64 rng(testing::kRandomSeed + 1);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (ForcePair& pair : pairs) {
    pair.reference_n.head<2>() = Eigen::Vector2d(noise(rng), noise(rng));
    pair.measured_n.head<2>() = Eigen::Vector2d(noise(rng), noise(rng));
  }
  for (int axis = 0; axis < 2; ++axis) {
    double mr = 0.0;
    for (const ForcePair& pair : pairs) mr += pair.measured_n(axis) * pair.reference_n(axis);
    if (mr < 0.0) {
      for (ForcePair& pair : pairs) pair.measured_n(axis) *= -1.0;
    }
  }
  return pairs;
}

// Issue 27: R^2 -0.08 and -1.00 were printed as usable gains.
TEST(FitForceGains, AFitOnNoiseIsRefusedNamingTheAxesAndTheFloor) {
  const std::vector<ForcePair> pairs = NoiseInXAndY(30);
  try {
    FitForceGains(pairs);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::ContainsRegex("the fx gain's R\\^2 is -?0\\.[0-9]{3}, the fy gain's "
                                                  "R\\^2 is -?0\\.[0-9]{3} \\(over 30 pairs\\), under "
                                                  "the floor 0\\.9"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("add presses with shear"));
    EXPECT_THAT(e.what(), ::testing::Not(::testing::HasSubstr("fz")));
  }
  // Flagged instead of refused: the same fit, marked unusable on x and y only.
  const ForceGainFit flagged = FitForceGains(pairs, {.on_poor_fit = PoorGainFit::kFlag});
  EXPECT_LT(flagged.r_squared.x(), 0.5);
  EXPECT_LT(flagged.r_squared.y(), 0.5);
  EXPECT_FALSE(flagged.usable(0));
  EXPECT_FALSE(flagged.usable(1));
  EXPECT_TRUE(flagged.usable(2));
  EXPECT_FALSE(flagged.usable());
  const nlohmann::json j = ToJson(flagged);
  EXPECT_EQ(j.at("usable"), false);
  EXPECT_EQ(j.at("min_r_squared"), kDefaultMinGainRSquared);
  EXPECT_EQ(j.at("warning"), flagged.PoorFitMessage());
  // A floor low enough takes it.
  EXPECT_TRUE(FitForceGains(pairs, {.min_r_squared = -10.0}).usable());
}

TEST(FitForceGains, LeftAtOneFitsTheDeterminedAxesAndSaysWhyTheOthersAreNot) {
  // z well loaded at gain 1.2; x and y noise only: the pairs determine z alone.
  std::vector<ForcePair> pairs = NoiseInXAndY(30);
  for (ForcePair& pair : pairs) pair.measured_n.z() = pair.reference_n.z() / 1.2;
  const ForceGainFit fit = FitForceGains(pairs, {.on_poor_fit = PoorGainFit::kLeaveAtOne});
  EXPECT_NEAR(fit.gains.z(), 1.2, 1e-12);
  EXPECT_EQ(fit.left_at_one[2], "");
  EXPECT_EQ(fit.gains.x(), 1.0);
  EXPECT_EQ(fit.gains.y(), 1.0);
  EXPECT_THAT(fit.left_at_one[0], ::testing::HasSubstr("under 0.9: the pairs do not determine it"));
  EXPECT_TRUE(fit.usable());
  EXPECT_EQ(ToJson(fit).at("left_at_one").size(), 2u);
  // An axis never loaded, or one whose sign disagrees, is left at 1 too instead of refused.
  for (ForcePair& pair : pairs) {
    pair.measured_n.x() = 0.0;
    pair.measured_n.y() = -pair.reference_n.y();
  }
  const ForceGainFit odd = FitForceGains(pairs, {.on_poor_fit = PoorGainFit::kLeaveAtOne});
  EXPECT_EQ(odd.gains, Eigen::Vector3d(1.0, 1.0, odd.gains.z()));
  EXPECT_EQ(odd.left_at_one[0], "every measured fx is zero");
  EXPECT_THAT(odd.left_at_one[1], ::testing::HasSubstr("disagree in sign"));
  EXPECT_THROW(FitForceGains(pairs), Error);
}

TEST(FitForceGains, AGoodFitPassesTheFloor) {
  const ForceGainFit fit = FitForceGains(RandomPairs(Eigen::Vector3d(1.1, 0.9, 1.2), 0.05, 30));
  EXPECT_TRUE(fit.usable());
  EXPECT_EQ(fit.PoorFitMessage(), "");
  EXPECT_EQ(ToJson(fit).at("usable"), true);
  EXPECT_FALSE(ToJson(fit).contains("warning"));
}

TEST(FitForceGains, AFloorAboveOneIsRefused) {
  const std::vector<ForcePair> pairs = RandomPairs(Eigen::Vector3d::Ones(), 0.0, 5);
  EXPECT_THAT([&] { FitForceGains(pairs, {.min_r_squared = 1.5}); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("min_r_squared")));
  EXPECT_THROW(FitForceGains(pairs, {.min_r_squared = std::nan("")}), Error);
}

TEST(ForcePairCsv, RoundTripsExactly) {
  const std::vector<ForcePair> pairs = RandomPairs(Eigen::Vector3d(1.1, 0.9, 1.2), 0.01, 7);
  const std::vector<ForcePair> parsed = ParseForcePairs(ForcePairsToCsv(pairs));
  ASSERT_EQ(parsed.size(), pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_EQ(parsed[k].measured_n, pairs[k].measured_n);
    EXPECT_EQ(parsed[k].reference_n, pairs[k].reference_n);
  }
}

TEST(ForcePairCsv, AcceptsCommentsBlankLinesAndSpaces) {
  const std::string text =
      "# presses of 2022-11-22\n"
      "fx_meas, fy_meas, fz_meas, fx_ref, fy_ref, fz_ref\r\n"
      "\n"
      " 0.1, -0.2, -3.5, 0.11 ,-0.19, -3.4\n"
      "# a comment between pairs\n"
      "0,0,-1e1,0,0,-9.5\n";
  const std::vector<ForcePair> pairs = ParseForcePairs(text, "pairs.csv");
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].measured_n, Eigen::Vector3d(0.1, -0.2, -3.5));
  EXPECT_EQ(pairs[1].reference_n, Eigen::Vector3d(0, 0, -9.5));
}

TEST(ForcePairCsv, MalformedLinesAreRefusedWithTheirNumbers) {
  const std::string text =
      "fx_meas,fy_meas,fz_meas,fx_ref,fy_ref,fz_ref\n"
      "1,2,3,4,5,6\n"
      "1,2,3,4,5\n"         // line 3: 5 fields
      "1,2,3,4,5,6,\n"      // line 4: trailing comma
      "1,2,x,4,5,6\n"       // line 5: not a number
      "1,2,nan,4,5,6\n"     // line 6: not finite
      "1,2,3,4,5,6\n";
  try {
    ParseForcePairs(text, "pairs.csv");
    FAIL() << "no throw";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("4 malformed"), std::string::npos) << message;
    for (const char* where : {"pairs.csv:3: expected 6 fields, got 5",
                              "pairs.csv:4: expected 6 fields, got 7", "pairs.csv:5: field 3 'x'",
                              "pairs.csv:6: field 3 'nan'"}) {
      EXPECT_NE(message.find(where), std::string::npos) << message;
    }
    EXPECT_EQ(message.find("pairs.csv:2:"), std::string::npos) << message;
  }
}

TEST(ForcePairCsv, HeaderAndEmptinessAreChecked) {
  EXPECT_THROW(ParseForcePairs(""), Error);
  EXPECT_THROW(ParseForcePairs("1,2,3,4,5,6\n"), Error);
  EXPECT_THROW(ParseForcePairs("fx_ref,fy_ref,fz_ref,fx_meas,fy_meas,fz_meas\n1,2,3,4,5,6\n"), Error);
  EXPECT_THROW(ParseForcePairs(std::string(kForcePairCsvHeader) + "\n"), Error);
}

// Issue 22, defect 11: calibrate-force printed "the fx gain is -nan" for pairs of 1e300 (their
// squares overflow), and echoed a 26 KB first line whole.
TEST(ForcePairCsv, HugeValuesAndLongLinesAreRefusedShortly) {
  const std::string huge = std::string(kForcePairCsvHeader) + "\n1,2,3,4,5,6\n1e300,2,3,4,5,6\n";
  EXPECT_THAT([&] { ParseForcePairs(huge, "pairs.csv"); },
              ::testing::ThrowsMessage<Error>(
                  ::testing::HasSubstr("pairs.csv:3: field 1 '1e300' is beyond +-10000")));
  const std::string long_line = std::string(26000, 'x') + "\n1,2,3,4,5,6\n";
  try {
    ParseForcePairs(long_line, "pairs.csv");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("got '" + std::string(60, 'x') + "...'"));
    EXPECT_LT(std::string(e.what()).size(), 300u);
  }
  const std::string presses = std::string(kCalibrationPressCsvHeader) + "\n1,2,3,0,0,1e5\n";
  EXPECT_THAT([&] { ParseCalibrationPresses(presses, 1, "presses.csv"); },
              ::testing::ThrowsMessage<Error>(
                  ::testing::HasSubstr("presses.csv:2: field 6 '1e5' is beyond +-10000")));
}

TEST(ForcePairCsv, LoadsAFile) {
  const std::string path = testing::MakeTempDir("csv") + "/pairs.csv";
  std::ofstream(path) << kForcePairCsvHeader << "\n1,2,3,1.1,2.2,3.3\n";
  EXPECT_EQ(LoadForcePairs(path).size(), 1u);
  EXPECT_THROW(LoadForcePairs(path + ".missing"), Error);
}

TEST(CalibrationPressCsv, RoundTripsExactly) {
  const std::vector<CalibrationPress> presses = {
      {Eigen::VectorXd::LinSpaced(6, -0.1, 0.35), Eigen::Vector3d(0.1, -1.0 / 3.0, -4.9), std::nullopt},
      {Eigen::VectorXd::Constant(6, 1e-5), Eigen::Vector3d(0, 0, -1), std::nullopt}};
  const std::vector<CalibrationPress> parsed =
      ParseCalibrationPresses(CalibrationPressesToCsv(presses), 2);
  ASSERT_EQ(parsed.size(), 2u);
  for (size_t k = 0; k < presses.size(); ++k) {
    EXPECT_TRUE(parsed[k].displacement_mm == presses[k].displacement_mm);
    EXPECT_TRUE(parsed[k].reference_n == presses[k].reference_n);
  }
}

TEST(CalibrationPressCsv, RoundTripsTheContactCentres) {
  std::vector<CalibrationPress> presses = {
      {Eigen::VectorXd::LinSpaced(6, -0.1, 0.35), Eigen::Vector3d(0.1, -0.2, -4.9),
       Eigen::Vector2d(1.0 / 3.0, -2.5)},
      {Eigen::VectorXd::Constant(6, 1e-5), Eigen::Vector3d(0, 0, -1), Eigen::Vector2d(0, 0)}};
  const std::string csv = CalibrationPressesToCsv(presses);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), kCalibrationPressWithCenterCsvHeader);
  const std::vector<CalibrationPress> parsed = ParseCalibrationPresses(csv, 2);
  ASSERT_EQ(parsed.size(), 2u);
  for (size_t k = 0; k < presses.size(); ++k) {
    EXPECT_TRUE(parsed[k].displacement_mm == presses[k].displacement_mm);
    EXPECT_TRUE(parsed[k].reference_n == presses[k].reference_n);
    ASSERT_TRUE(parsed[k].contact_center_mm.has_value());
    EXPECT_TRUE(*parsed[k].contact_center_mm == *presses[k].contact_center_mm);
  }
  // A centre for some presses only cannot be written.
  presses[1].contact_center_mm.reset();
  EXPECT_THROW(CalibrationPressesToCsv(presses), Error);
}

TEST(CalibrationPressCsv, AWrongMarkerCountIsReportedPerLine) {
  const std::string text =
      std::string(kCalibrationPressCsvHeader) + "\n0,0,-1,1,2,3,4,5,6\n0,0,-1,1,2,3\n";
  try {
    ParseCalibrationPresses(text, 2, "presses.csv");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("presses.csv:3: expected 9 fields, got 6"));
  }
  EXPECT_THROW(ParseCalibrationPresses(std::string(kForcePairCsvHeader) + "\n1,2,3,4,5,6\n", 1),
               Error);
}

}  // namespace
}  // namespace tac3d
