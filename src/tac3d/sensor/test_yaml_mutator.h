#pragma once

// Seeded mutations of a YAML text for the fuzz tests of the readers (sensor config, run file):
// nasty values, flipped bytes, deleted runs, duplicated lines, second documents, nested
// aliases, punctuation.

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::testing {

// Values that have broken readers: huge, tiny, negative, non-finite, non-numeric, YAML syntax.
inline const std::vector<std::string> kNastyValues = {
    "1e300",  "-1e300",     "2e9", "2000000000", "-1",     "0", ".nan", ".inf", "-.inf",
    "1e-320", "10000",      "'x'", "[1, 2]",     "{a: 1}", "~", "&a 1", "*a",   "!!binary aGVsbG8=",
    "[[[[[[", "\"\\u0000\""};

class YamlMutator {
 public:
  explicit YamlMutator(std::string seed_text)
      : seed_(std::move(seed_text)), rng_(kRandomSeed) {}

  std::string Next() {
    std::string text = seed_;
    const int edits = Uniform(1, 4);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const size_t at = Uniform(0, static_cast<int>(text.size()) - 1);
      switch (Uniform(0, 6)) {
        case 0: {  // replace the value after a colon on this line
          const size_t colon = text.find(": ", at);
          const size_t end = colon == std::string::npos ? colon : text.find('\n', colon);
          if (end != std::string::npos)
            text.replace(colon + 2, end - colon - 2, Pick(kNastyValues));
          break;
        }
        case 1:  // flip a byte
          text[at] = static_cast<char>(Uniform(0, 255));
          break;
        case 2:  // delete a run
          text.erase(at, Uniform(1, 40));
          break;
        case 3: {  // duplicate a line
          const size_t begin = text.rfind('\n', at);
          const size_t end = text.find('\n', at);
          if (begin != std::string::npos && end != std::string::npos) {
            text.insert(end, text.substr(begin, end - begin));
          }
          break;
        }
        case 4:  // a second document
          text += "---\n" + text.substr(0, at);
          break;
        case 5:  // nested aliases: up to 10^8 values expanded
          text = NestedAliases(Uniform(1, 8), Uniform(1, 10)) + text;
          break;
        default:  // insert YAML punctuation
          text.insert(at,
                      Pick({"- ", ": ", "[", "]", "{", "}", "\n  ", "#", "&x ", "*x", "---\n"}));
      }
    }
    return text;
  }

 private:
  int Uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  // `levels` keys, each a list of `width` aliases of the one before: width^levels values.
  static std::string NestedAliases(int levels, int width) {
    std::string text = "l0: &l0 [x]\n";
    for (int level = 1; level < levels; ++level) {
      text += fmt::format("l{0}: &l{0} [", level);
      for (int k = 0; k < width; ++k) text += fmt::format("{}*l{}", k ? ", " : "", level - 1);
      text += "]\n";
    }
    return text;
  }
  std::string Pick(const std::vector<std::string>& v) {
    return v[Uniform(0, static_cast<int>(v.size()) - 1)];
  }

  std::string seed_;
  std::mt19937 rng_;
};

struct FuzzCounts {
  int iterations = 0;
  int loaded = 0;   ///< parsed
  int refused = 0;  ///< threw tac3d::Error
};

/// Parses mutations of `seed` with `parse` (up to 20000, or 10 s), the address space capped at
/// 2 GiB so an allocation driven by a value in the text shows up as std::bad_alloc: each must
/// load or throw tac3d::Error; anything else is a test failure naming the text. Prints the
/// counts, after `what`.
inline FuzzCounts FuzzYamlReader(const std::string& seed, const std::function<void(const std::string&)>& parse,
                                 const char* what) {
  rlimit limit{};
  EXPECT_EQ(::getrlimit(RLIMIT_AS, &limit), 0);
  const rlimit saved = limit;
  limit.rlim_cur = std::min<rlim_t>(limit.rlim_max, rlim_t{2} << 30);  // 2 GiB
  EXPECT_EQ(::setrlimit(RLIMIT_AS, &limit), 0);
  YamlMutator mutator(seed);
  const auto start = std::chrono::steady_clock::now();
  FuzzCounts counts;
  for (; counts.iterations < 20000 && std::chrono::steady_clock::now() - start < std::chrono::seconds(10);
       ++counts.iterations) {
    const std::string text = mutator.Next();
    try {
      parse(text);
      ++counts.loaded;
    } catch (const Error&) {
      ++counts.refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a tac3d::Error: " << e.what() << "\non:\n" << text;
    }
  }
  ::setrlimit(RLIMIT_AS, &saved);
  std::printf("%d mutated %s: %d loaded, %d refused\n", counts.iterations, what, counts.loaded, counts.refused);
  return counts;
}

}  // namespace tac3d::testing
