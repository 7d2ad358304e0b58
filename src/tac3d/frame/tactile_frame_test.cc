#include "tac3d/frame/tactile_frame.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

std::string ErrorOf(const TactileFrame& frame) {
  try {
    frame.Validate();
  } catch (const Error& e) {
    return e.what();
  }
  return "accepted";
}

TEST(TactileFrame, SizedFrameIsValidAndRowMajor) {
  const TactileFrame frame = TactileFrame::Sized(3, 5);
  EXPECT_EQ(frame.num_markers(), 15);
  EXPECT_EQ(frame.positions_mm.size(), 15u);
  EXPECT_EQ(frame.valid.size(), 15u);
  EXPECT_EQ(ErrorOf(frame), "accepted");
  EXPECT_THROW(TactileFrame::Sized(0, 20), Error);
}

// Issue 22, defect 10: TactileFrame(10**6, 10**6) in Python was not bounded.
TEST(TactileFrame, GridLargerThanAnySensorsIsRefused) {
  EXPECT_NO_THROW(TactileFrame::Sized(TactileFrame::kMaxGridSide, TactileFrame::kMaxGridSide));
  EXPECT_THAT([] { TactileFrame::Sized(1000000, 1000000); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "TactileFrame: grid 1000000 x 1000000 must be within 1 x 1 .. 100 x 100")));
  TactileFrame frame = TactileFrame::Sized(2, 2);
  frame.rows = 101;
  EXPECT_THAT(ErrorOf(frame), ::testing::HasSubstr("grid 101 x 2 must be within"));
}

TEST(TactileFrame, FlagsSetClearAndName) {
  TactileFrame frame = TactileFrame::Sized(2, 2);
  frame.set(FrameFlag::kMarkersLost);
  frame.set(FrameFlag::kForceOutOfRange);
  EXPECT_TRUE(frame.has(FrameFlag::kMarkersLost));
  EXPECT_FALSE(frame.has(FrameFlag::kGridReacquired));
  EXPECT_EQ(FrameFlagNames(frame.flags), "markers_lost force_out_of_range");
  frame.set(FrameFlag::kMarkersLost, false);
  EXPECT_EQ(FrameFlagNames(frame.flags), "force_out_of_range");
  EXPECT_EQ(FrameFlagNames(0), "");
  frame.flags = 0;
  frame.set(FrameFlag::kLightingChanged);
  frame.set(FrameFlag::kDriftAtRest);
  EXPECT_EQ(FrameFlagNames(frame.flags), "lighting_changed drift_at_rest");
  EXPECT_NO_THROW(frame.Validate());
}

TEST(TactileFrame, ValidateNamesTheBrokenField) {
  TactileFrame frame = TactileFrame::Sized(20, 20);
  frame.forces_n.pop_back();
  EXPECT_THAT(ErrorOf(frame), HasSubstr("forces_n has 399 entries"));
  frame = TactileFrame::Sized(20, 20);
  frame.contact.push_back(true);
  EXPECT_THAT(ErrorOf(frame), HasSubstr("contact has 401"));
  frame = TactileFrame::Sized(20, 20);
  frame.initialize_progress = 101;
  EXPECT_THAT(ErrorOf(frame), HasSubstr("initialize_progress 101"));
  frame = TactileFrame::Sized(20, 20);
  frame.timestamp_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(ErrorOf(frame), HasSubstr("timestamp_s"));
  frame = TactileFrame::Sized(20, 20);
  frame.flags = 1u << 31;
  EXPECT_THAT(ErrorOf(frame), HasSubstr("unknown bits"));
  frame = TactileFrame::Sized(20, 20);
  frame.rows = 0;
  EXPECT_THAT(ErrorOf(frame), HasSubstr("grid 0 x 20 must be within 1 x 1 .. 100 x 100"));
}

// A NaN on a valid marker reached the friction map's reconstruction (a crash); a lost marker
// may carry anything.
TEST(TactileFrame, AValidMarkerMustBeFiniteALostOneNeedNot) {
  TactileFrame frame = TactileFrame::Sized(20, 20);
  frame.positions_mm[7].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(ErrorOf(frame), HasSubstr("marker 7 is valid but its position, displacement or force "
                                        "is not finite"));
  frame.valid[7] = false;
  EXPECT_NO_THROW(frame.Validate());
  frame = TactileFrame::Sized(20, 20);
  frame.forces_n[3].z() = std::numeric_limits<double>::infinity();
  EXPECT_THAT(ErrorOf(frame), HasSubstr("marker 3 is valid"));
  // Normals not sent over UDP are NaN, "not measured", on a valid marker.
  frame = TactileFrame::Sized(20, 20);
  frame.normals[3].setConstant(std::numeric_limits<double>::quiet_NaN());
  EXPECT_NO_THROW(frame.Validate());
}

TEST(TactileFrame, EqualityComparesEveryField) {
  const TactileFrame a = TactileFrame::Sized(2, 2);
  TactileFrame b = a;
  EXPECT_EQ(a, b);
  b.normals[3].z() = 1.0;
  EXPECT_NE(a, b);
  b = a;
  b.contact[1] = true;
  EXPECT_NE(a, b);
}

TEST(SyntheticTactileFrame, ResultantsAreTheMarkerSumsAndTheFrameIsValid) {
  const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0001L", 17);
  EXPECT_NO_THROW(frame.Validate());
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
  for (int i = 0; i < frame.num_markers(); ++i) {
    force += frame.forces_n[i];
    moment += frame.positions_mm[i].cross(frame.forces_n[i]);
    EXPECT_NEAR(frame.normals[i].norm(), 1.0, 1e-12);
  }
  EXPECT_THAT(frame.resultant_force_n, EigenNear(force, 1e-12));
  EXPECT_THAT(frame.resultant_moment_nmm, EigenNear(moment, 1e-9));
  EXPECT_LT(frame.resultant_force_n.z(), -0.01);  // the dent presses in
  EXPECT_FALSE(frame.valid[17]);
  EXPECT_TRUE(frame.has(FrameFlag::kMarkersLost));
  EXPECT_NE(frame, MakeSyntheticTactileFrame("AD2-0001L", 18));
}

}  // namespace
}  // namespace tac3d

namespace tac3d {
namespace {

TEST(TactileFrame, SlipStartsUnknownComparesNaNsEqualAndRefusesABadState) {
  TactileFrame frame = TactileFrame::Sized(2, 2);
  EXPECT_EQ(frame.slip.state, SlipState::kUnknown);
  EXPECT_TRUE(std::isnan(frame.slip.fraction));
  EXPECT_EQ(frame, TactileFrame::Sized(2, 2));  // NaN slip values equal their copy
  TactileFrame other = frame;
  other.slip.friction = 0.4;
  EXPECT_FALSE(frame == other);
  EXPECT_STREQ(SlipStateName(SlipState::kPartialSlip), "partial_slip");
  EXPECT_STREQ(SlipStateName(SlipState::kNone), "none");
  frame.slip.state = static_cast<SlipState>(kNumSlipStates);
  EXPECT_THROW(frame.Validate(), Error);
}

}  // namespace
}  // namespace tac3d
