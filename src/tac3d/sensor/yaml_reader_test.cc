#include "tac3d/sensor/yaml_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// `levels` keys, each a list of ten aliases of the one before: 10^levels values expanded.
std::string TenfoldAliases(int levels) {
  std::string text = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int level = 1; level < levels; ++level) {
    text += fmt::format("a{0}: &a{0} [", level);
    for (int k = 0; k < 10; ++k) text += fmt::format("{}*a{}", k ? ", " : "", level - 1);
    text += "]\n";
  }
  return text;
}

TEST(ParseYamlDocument, AliasesWithinTheBoundAreExpanded) {
  const YAML::Node root = ParseYamlDocument(
      "base: &base {x: 1, y: 2}\nleft: *base\nright: [*base, *base]\n" + TenfoldAliases(3),
      "ok.yaml");
  EXPECT_EQ(root["left"]["y"].as<int>(), 2);
  EXPECT_EQ(root["right"][1]["x"].as<int>(), 1);
  EXPECT_EQ(root["a2"][9][9][9].as<std::string>(), "x");
}

// Issue 22, defect 7: eight levels of ten (332 bytes) made every reader walk 10^8 values
// (`tac3d design --config` ran 60 s+); the walk is refused at the alias that crosses the bound:
// line 4's level (10^4 values), not after walking the levels below it.
TEST(ParseYamlDocument, NestedAliasesPastTheBoundAreRefusedAtOnce) {
  EXPECT_THAT([] { ParseYamlDocument(TenfoldAliases(8), "bomb.yaml"); },
              ThrowsMessage<Error>(HasSubstr(
                  "bomb.yaml: line 4: the aliases (*name) stand for more than 10000 values in all")));
  // 10000 exactly is allowed: 1000 aliases of a list of 9 values (10 with the list).
  std::string many = "l: &l [1, 2, 3, 4, 5, 6, 7, 8, 9]\nall:\n";
  for (int k = 0; k < 1000; ++k) many += "  - *l\n";
  EXPECT_NO_THROW(ParseYamlDocument(many, "many.yaml"));
  EXPECT_THAT([&] { ParseYamlDocument(many + "  - *l\n", "many.yaml"); },
              ThrowsMessage<Error>(HasSubstr("many.yaml: line 1003: the aliases")));
}

// An alias inside the node it names made yaml-cpp build a cycle, and the duplicate-key check
// recurse until the stack overflowed (SIGSEGV).
TEST(ParseYamlDocument, AnAliasInsideItsOwnNodeIsRefused) {
  EXPECT_THAT([] { ParseYamlDocument("a: &a [1, *a]\n", "self.yaml"); },
              ThrowsMessage<Error>(HasSubstr(
                  "self.yaml: line 1: an alias (*name) inside the node it names")));
  EXPECT_THAT([] { ParseYamlDocument("a: &a {b: {c: *a}}\n", "self.yaml"); },
              ThrowsMessage<Error>(HasSubstr("inside the node it names")));
}

TEST(ParseYamlDocument, ASecondDocumentIsStillRefused) {
  EXPECT_THAT([] { ParseYamlDocument("a: 1\n---\nb: &b [*b]\n", "two.yaml"); },
              ThrowsMessage<Error>(HasSubstr("inside the node it names")));
  EXPECT_THAT([] { ParseYamlDocument("a: 1\n---\nb: 2\n", "two.yaml"); },
              ThrowsMessage<Error>(HasSubstr("two.yaml: line 2: a second YAML document")));
}

}  // namespace
}  // namespace tac3d
