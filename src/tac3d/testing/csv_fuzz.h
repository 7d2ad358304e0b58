#pragma once

#include <sys/resource.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::testing {

/// Seeded fuzzing of a CSV file reader: `seed_text` mutated line- and byte-wise
/// (fields replaced by huge, non-finite or non-numeric values, bytes flipped, runs deleted,
/// lines duplicated many times, NUL bytes), written to a file and read with `read`, which must
/// return or throw tac3d::Error within bounded time and memory (the address space is capped
/// at 2 GiB, so an allocation without bound fails as std::bad_alloc). Then the special files:
/// /dev/zero, a folder, a FIFO (which would block a reader that opens it). Runs for at most
/// `seconds`; @return the number of mutated files read.
inline int FuzzCsvReader(const std::string& seed_text,
                         const std::function<void(const std::string& path)>& read,
                         int seconds = 5) {
  rlimit limit{};
  EXPECT_EQ(::getrlimit(RLIMIT_AS, &limit), 0);
  const rlimit saved = limit;
  limit.rlim_cur = std::min<rlim_t>(limit.rlim_max, rlim_t{2} << 30);
  EXPECT_EQ(::setrlimit(RLIMIT_AS, &limit), 0);
  std::mt19937 rng(kRandomSeed);
  const auto uniform = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  const std::vector<std::string> nasty = {"1e300", "-1e308", "nan", "inf", "", "x", "1e-320",
                                          "0x10", "1,2", std::string(5000, '9')};
  const std::string dir = MakeTempDir("csv_fuzz");
  const std::string path = dir + "/fuzz.csv";
  const auto read_and_judge = [&](const std::string& file, const std::string& text) {
    try {
      read(file);
    } catch (const Error&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a tac3d::Error: " << e.what() << "\non:\n" << text.substr(0, 500);
    }
  };
  int iterations = 0;
  const auto start = std::chrono::steady_clock::now();
  for (; iterations < 5000 && std::chrono::steady_clock::now() - start < std::chrono::seconds(seconds);
       ++iterations) {
    std::string text = seed_text;
    for (int e = uniform(1, 4); e > 0 && !text.empty(); --e) {
      const size_t at = uniform(0, static_cast<int>(text.size()) - 1);
      const size_t line_begin = text.rfind('\n', at) == std::string::npos ? 0 : text.rfind('\n', at) + 1;
      const size_t line_end = std::min(text.find('\n', at), text.size());
      switch (uniform(0, 5)) {
        case 0: {  // replace a field
          const size_t comma = text.find(',', at);
          const size_t end = std::min({comma, line_end, text.size()});
          text.replace(at, end - at, nasty[uniform(0, static_cast<int>(nasty.size()) - 1)]);
          break;
        }
        case 1:
          text[at] = static_cast<char>(uniform(0, 255));
          break;
        case 2:
          text.erase(at, uniform(1, 40));
          break;
        case 3: {  // a line many times over (at most ~1 MB of copies)
          const std::string line = text.substr(line_begin, line_end - line_begin) + "\n";
          std::string copies;
          for (int k = std::min<int>(uniform(1, 2000), (1 << 20) / line.size()); k > 0; --k) copies += line;
          text.insert(std::min(line_end + 1, text.size()), copies);
          break;
        }
        case 4:
          text.insert(at, std::string(uniform(1, 3), '\0'));
          break;
        default:
          text.insert(at, std::string(uniform(1, 10000), ','));
      }
    }
    std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
    read_and_judge(path, text);
  }
  const std::string fifo = dir + "/fifo.csv";
  EXPECT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& special : {std::string("/dev/zero"), dir, fifo}) {
    EXPECT_THROW(read(special), Error) << special;
  }
  ::setrlimit(RLIMIT_AS, &saved);
  return iterations;
}

}  // namespace tac3d::testing
