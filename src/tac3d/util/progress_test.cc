#include "tac3d/util/progress.h"

#include <string>

#include <gtest/gtest.h>

namespace tac3d {
namespace {

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Under ctest stderr is a pipe, which is the log mode this checks: a line on entering each
// tenth (0% to 100%: 11 lines), the 100% one not repeated by Finish.
TEST(ProgressBar, LogModePrintsEachDecileOnceAndOneFinalLine) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("work", 20);
    for (long i = 1; i <= 20; ++i) bar.Update(i);
    bar.Finish();
  }
  const std::string log = testing::internal::GetCapturedStderr();
  EXPECT_EQ(Count(log, "\n"), 11) << log;
  EXPECT_EQ(Count(log, "100%"), 1) << log;
}

TEST(ProgressBar, FinishWithoutUpdatesPrintsTheCompleteLineOnce) {
  testing::internal::CaptureStderr();
  { ProgressBar bar("work", 5); }
  const std::string log = testing::internal::GetCapturedStderr();
  EXPECT_EQ(Count(log, "100%"), 1) << log;
}

TEST(ProgressBar, DisabledIsSilent) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("work", 5, /*enabled=*/false);
    bar.Update(3);
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

}  // namespace
}  // namespace tac3d
