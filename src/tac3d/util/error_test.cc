#include "tac3d/util/error.h"

#include <gtest/gtest.h>

#include <string>

namespace tac3d {
namespace {

// A binary spec's bytes echoed in a message made it unprintable (Python showed an empty one).
TEST(Error, BytesThatAreNotPrintableUtf8AreEscaped) {
  EXPECT_STREQ(Error("plain text, line 3: mu").what(), "plain text, line 3: mu");
  EXPECT_STREQ(Error(std::string("two\nlines\tand a tab")).what(), "two\nlines\tand a tab");
  EXPECT_STREQ(Error("\xc2\xb5m and \xe2\x80\x94 and \xf0\x9f\x98\x80").what(), "\xc2\xb5m and \xe2\x80\x94 and \xf0\x9f\x98\x80");
  constexpr char kControls[] = "nul \0 bell \x07 del \x7f";
  EXPECT_STREQ(Error(std::string(kControls, sizeof(kControls) - 1)).what(), "nul \\x00 bell \\x07 del \\x7f");
  EXPECT_STREQ(Error("stray \x80, cut \xe2\x80, overlong \xc0\xaf, C1 \xc2\x85").what(),
               "stray \\x80, cut \\xe2\\x80, overlong \\xc0\\xaf, C1 \\xc2\\x85");
  EXPECT_STREQ(Error("surrogate \xed\xa0\x80 end \xff").what(), "surrogate \\xed\\xa0\\x80 end \\xff");
}

}  // namespace
}  // namespace tac3d
