#include "tac3d/util/eval_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

namespace tac3d {
namespace {

TEST(EvalCheck, BoundsAndNonFiniteValues) {
  EXPECT_TRUE(EvalCheck::AtMost("e", 2.0, 2.0, "%").pass);
  EXPECT_FALSE(EvalCheck::AtMost("e", 2.01, 2.0, "%").pass);
  EXPECT_TRUE(EvalCheck::AtLeast("c", 0.9, 0.8).pass);
  EXPECT_FALSE(EvalCheck::AtLeast("c", 0.7, 0.8).pass);
  // A NaN figure never passes a bound, however it compares.
  EXPECT_FALSE(EvalCheck::AtMost("e", NAN, 2.0).pass);
  EXPECT_FALSE(EvalCheck::AtLeast("c", NAN, 0.8).pass);
  EXPECT_TRUE(EvalCheck::NotApplicable("b", 1.27, EvalCheck::Bound::kAtMost, "mm").pass);
}

TEST(EvalCheck, AllPassNeedsAtLeastOneCheck) {
  EXPECT_FALSE(AllPass({}));
  EXPECT_TRUE(AllPass({EvalCheck::AtMost("a", 1, 2), EvalCheck::AtLeast("b", 3, 2)}));
  EXPECT_FALSE(AllPass({EvalCheck::AtMost("a", 1, 2), EvalCheck::AtLeast("b", 1, 2)}));
}

TEST(EvalCheck, RoundTripsThroughJsonAndPrintsOneWay) {
  const EvalCheck checks[] = {EvalCheck::AtMost("resultant_error", 1.25, 2.0, "% FS"),
                              EvalCheck::AtLeast("coverage", 0.7, 0.8),
                              EvalCheck::NotApplicable("boundary_error", 1.27,
                                                       EvalCheck::Bound::kAtMost, "mm")};
  for (const EvalCheck& check : checks) {
    const EvalCheck back = EvalCheckFromJson(nlohmann::json::parse(ToJson(check).dump()));
    EXPECT_EQ(back.Format(), check.Format());
    EXPECT_EQ(back.pass, check.pass);
  }
  EXPECT_EQ(checks[0].Format(), "ok   resultant_error                      1.25 % FS (<= 2 % FS)");
  EXPECT_EQ(checks[1].Format(), "FAIL coverage                             0.7 (>= 0.8)");
  EXPECT_EQ(checks[2].Format(), "ok   boundary_error                       n/a (<= 1.27 mm)");
  EXPECT_TRUE(ToJson(checks[2]).at("value").is_null());
  EXPECT_EQ(FormatChecks({checks[0], checks[1]}),
            checks[0].Format() + "\n" + checks[1].Format() + "\n");
  EXPECT_EQ(FormatChecks({}), "");
}

}  // namespace
}  // namespace tac3d
