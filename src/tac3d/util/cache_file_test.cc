#include "tac3d/util/cache_file.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "tac3d/testing/testing.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

// A cached "model": a number in a text file, its key on the first line.
struct CachedNumber {
  std::uint64_t key = 0;
  int model = 0;
};

CachedNumber ReadNumber(const std::string& path) {
  std::ifstream in(path);
  CachedNumber cached;
  if (!(in >> cached.key >> cached.model)) throw Error("unreadable");
  return cached;
}

// Two processes building the same model both built it (minutes and gigabytes each): the second
// waits for the first's build and loads what it saved.
TEST(CacheFilePath, NamesTheKindAndTheKeyInHex) {
  EXPECT_EQ(CacheFilePath("/tmp/cache", "twin_body", 0x00ab12cd34ef5678u), "/tmp/cache/twin_body_00ab12cd34ef5678.bin");
  EXPECT_EQ(CacheFilePath("cache/", "compliance", 1), "cache/compliance_0000000000000001.bin");
}

TEST(LoadOrBuildCacheFile, ASecondBuilderWaitsForTheFirstAndLoadsItsFile) {
  const std::string path = testing::MakeTempDir("cache_lock") + "/model.bin";
  constexpr std::uint64_t kKey = 42;
  std::atomic<int> builds{0};
  const auto load_or_build = [&](int* model, CacheStatus* status) {
    std::string reason;
    *status = LoadOrBuildCacheFile(
        path, kKey, ReadNumber,
        [&] {
          ++builds;
          std::this_thread::sleep_for(std::chrono::milliseconds(300));  // long enough to overlap
          return 7;
        },
        [&](int value, const std::string& where) {
          WriteTextFileAtomically(where, std::to_string(kKey) + " " + std::to_string(value) + "\n");
        },
        model, &reason);
  };
  int first = 0, second = 0;
  CacheStatus first_status{}, second_status{};
  std::thread a([&] { load_or_build(&first, &first_status); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // most likely, a holds the lock
  std::thread b([&] { load_or_build(&second, &second_status); });
  a.join();
  b.join();
  EXPECT_EQ(builds.load(), 1);
  EXPECT_EQ(first, 7);
  EXPECT_EQ(second, 7);
  // One built it, the other loaded it (whichever took the lock first).
  EXPECT_TRUE((first_status == CacheStatus::kBuiltMissing && second_status == CacheStatus::kLoaded) ||
              (first_status == CacheStatus::kLoaded && second_status == CacheStatus::kBuiltMissing));
}

}  // namespace
}  // namespace tac3d
