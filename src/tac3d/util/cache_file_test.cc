#include "tac3d/util/cache_file.h"

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
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

TEST(CacheFilePath, NamesTheKindAndTheKeyInHex) {
  EXPECT_EQ(CacheFilePath("/tmp/cache", "twin_body", 0x00ab12cd34ef5678u), "/tmp/cache/twin_body_00ab12cd34ef5678.bin");
  EXPECT_EQ(CacheFilePath("cache/", "compliance", 1), "cache/compliance_0000000000000001.bin");
}

// What a load-or-build gives GetSharedModel.
struct LoadedNumber {
  int model = 0;
  CacheStatus status = CacheStatus::kLoaded;
  double elapsed_s = 0.0;
};

// One copy of a key's model for the process: loaded once while anyone holds it, each caller told
// how it got it (a file's load or build, or the copy in memory); once all let go, loaded again.
TEST(GetSharedModel, LoadsOnceWhileHeldAndSaysHowEachCallerGotIt) {
  SharedCache<std::uint64_t, int> models;
  int loads = 0;
  const auto load = [&] {
    ++loads;
    return LoadedNumber{7, CacheStatus::kBuiltMissing, 0.5};
  };
  SharedModelSource built, in_memory, again;
  std::shared_ptr<const int> first = GetSharedModel(models, 1, "cache/a.bin", load, &built);
  std::shared_ptr<const int> second = GetSharedModel(models, 1, "cache/a.bin", load, &in_memory);
  EXPECT_EQ(first, second);
  EXPECT_EQ(*first, 7);
  EXPECT_EQ(loads, 1);
  EXPECT_EQ(built.path, "cache/a.bin");
  EXPECT_EQ(built.status, CacheStatus::kBuiltMissing);
  EXPECT_EQ(built.elapsed_s, 0.5);
  EXPECT_EQ(in_memory.path, "cache/a.bin");
  EXPECT_FALSE(in_memory.status.has_value());
  EXPECT_EQ(in_memory.elapsed_s, 0.0);
  EXPECT_NE(GetSharedModel(models, 2, "cache/b.bin", load, nullptr), first);  // another key: its own
  EXPECT_EQ(loads, 2);
  const std::weak_ptr<const int> held = first;
  first.reset();
  second.reset();
  EXPECT_TRUE(held.expired());
  GetSharedModel(models, 1, "cache/a.bin", load, &again);
  EXPECT_EQ(loads, 3);
  EXPECT_EQ(again.status, CacheStatus::kBuiltMissing);
}

// Two processes building the same model both built it (minutes and gigabytes each): the second
// waits for the first's build and loads what it saved.
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
