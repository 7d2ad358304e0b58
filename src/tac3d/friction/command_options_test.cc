#include "tac3d/friction/command_options.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <type_traits>

#include "tac3d/util/error.h"

namespace tac3d::friction {
namespace {

TEST(FrictionMapCommandOptions, NamesAreSnakeCaseUniqueAndEachSetsItsOwnField) {
  std::set<std::string> names;
  std::set<std::string> fields;
  FrictionMapOptions options;
  for (const FrictionMapCommandOption& o : FrictionMapCommandOptions()) {
    EXPECT_TRUE(names.insert(o.name).second) << o.name;
    EXPECT_EQ(o.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz_"), std::string::npos) << o.name;
    EXPECT_FALSE(o.help.empty()) << o.name;
    EXPECT_EQ(FindFrictionMapCommandOption(o.name), &o);
    // Each option changes a field no other option has changed yet.
    const FrictionMapOptions before = options;
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(options.*member)>;
          if constexpr (std::is_same_v<T, bool>) {
            options.*member = !(options.*member);
          } else {
            options.*member = options.*member + T{7};
          }
        },
        o.field);
    const int changed = (before.contact_threshold_n != options.contact_threshold_n) +
                        (before.slip_contact_threshold_n != options.slip_contact_threshold_n) +
                        (before.tangential_motion != options.tangential_motion) +
                        (before.gross_slip_only != options.gross_slip_only) +
                        (before.friction_along_slip != options.friction_along_slip) +
                        (before.gross_slip_margin != options.gross_slip_margin) +
                        (before.slip_sigmas != options.slip_sigmas) +
                        (before.marker_noise_mm != options.marker_noise_mm) +
                        (before.pose_noise_mm != options.pose_noise_mm) +
                        (before.radius_mm != options.radius_mm) + (before.alpha != options.alpha) +
                        (before.beta != options.beta) +
                        (before.normal_force_exponent != options.normal_force_exponent) +
                        (before.min_slip_points != options.min_slip_points) +
                        (before.max_support_offset != options.max_support_offset) +
                        (before.voxel_size_mm != options.voxel_size_mm) +
                        (before.poisson_depth != options.poisson_depth) +
                        (before.poisson_scale != options.poisson_scale) +
                        (before.trim_distance_mm != options.trim_distance_mm) +
                        (before.num_threads != options.num_threads);
    EXPECT_EQ(changed, 1) << o.name;
  }
  // Every field but the sensor's cover thickness is an option.
  EXPECT_EQ(names.size(), 20u);
  EXPECT_EQ(options.cover_thickness_mm, FrictionMapOptions{}.cover_thickness_mm);
}

TEST(FrictionMapCommandOptions, FlagsAndUnknownNames) {
  EXPECT_EQ(FindFrictionMapCommandOption("gross_slip_margin")->Flag(), "--gross-slip-margin");
  EXPECT_EQ(FindFrictionMapCommandOption("radius")->Flag(), "--radius");
  EXPECT_EQ(FindFrictionMapCommandOption("radius_mm"), nullptr);
  EXPECT_EQ(FindFrictionMapCommandOption(""), nullptr);
  const std::string names = FrictionMapCommandOptionNames();
  EXPECT_EQ(names.substr(0, 38), "contact_threshold, slip_contact_thresh");
  EXPECT_NE(names.find(", threads"), std::string::npos);
}

std::string ValidationMessage(const FrictionMapOptions& options, OptionNaming naming) {
  try {
    ValidateCommandOptions(options, naming);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(FrictionMapCommandOptions, ValidationNamesTheOptionAsTheUserGaveIt) {
  FrictionMapOptions options = CommandFrictionMapDefaults();
  EXPECT_EQ(ValidationMessage(options, OptionNaming::kFlag), "");
  options.radius_mm = -1;
  EXPECT_EQ(ValidationMessage(options, OptionNaming::kFlag),
            "--radius = -1 is out of range: must be > 0 and finite");
  EXPECT_EQ(ValidationMessage(options, OptionNaming::kName),
            "radius = -1 is out of range: must be > 0 and finite");
  options = CommandFrictionMapDefaults();
  options.gross_slip_margin = -2;
  EXPECT_EQ(ValidationMessage(options, OptionNaming::kFlag),
            "--gross-slip-margin = -2 is out of range: must be >= 0");
  // Not an option (the sensor's): the field's name.
  options = CommandFrictionMapDefaults();
  options.cover_thickness_mm = 9;
  EXPECT_THAT(ValidationMessage(options, OptionNaming::kName),
              ::testing::StartsWith("FrictionMapOptions.cover_thickness_mm = 9"));
}

TEST(FrictionMapCommandOptions, DefaultsAreValidAndTheTwinEvaluationsWhereTheyDiffer) {
  const FrictionMapOptions d = CommandFrictionMapDefaults();
  EXPECT_NO_THROW(d.Validate());
  const FrictionMapOptions paper;
  EXPECT_EQ(d.beta, 0.0);
  EXPECT_EQ(d.normal_force_exponent, 1.0);
  EXPECT_EQ(d.min_slip_points, 30);
  EXPECT_EQ(d.max_support_offset, 0.3);
  EXPECT_EQ(d.slip_contact_threshold_n, 0.005);
  EXPECT_TRUE(d.tangential_motion && d.gross_slip_only && d.friction_along_slip);
  // The rest are the paper's.
  EXPECT_EQ(d.contact_threshold_n, paper.contact_threshold_n);
  EXPECT_EQ(d.radius_mm, paper.radius_mm);
  EXPECT_EQ(d.alpha, paper.alpha);
  EXPECT_EQ(d.slip_sigmas, paper.slip_sigmas);
  EXPECT_EQ(d.gross_slip_margin, paper.gross_slip_margin);
}

}  // namespace
}  // namespace tac3d::friction
