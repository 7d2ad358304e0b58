#include "tac3d/util/shared_cache.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace tac3d {
namespace {

TEST(SharedCache, OneKeyGivesOneObjectWhileHeldAndAnotherKeyItsOwn) {
  SharedCache<int, int> cache;
  int made = 0;
  const auto make = [&made](int value) {
    return [&made, value] {
      ++made;
      return std::make_shared<const int>(value);
    };
  };
  const std::shared_ptr<const int> a = cache.Get(1, make(10));
  const std::shared_ptr<const int> b = cache.Get(1, make(11));
  const std::shared_ptr<const int> c = cache.Get(2, make(20));
  EXPECT_EQ(a, b);  // the same object, not an equal one
  EXPECT_EQ(*b, 10);
  EXPECT_NE(a, c);
  EXPECT_EQ(*c, 20);
  EXPECT_EQ(made, 2);
}

TEST(SharedCache, AValueIsFreedWithItsLastHolderAndMadeAnewWhenAskedAgain) {
  SharedCache<int, int> cache;
  std::weak_ptr<const int> weak = cache.Get(1, [] { return std::make_shared<const int>(10); });
  EXPECT_TRUE(weak.expired());  // the cache holds no strong reference
  int made = 0;
  const std::shared_ptr<const int> again = cache.Get(1, [&made] {
    ++made;
    return std::make_shared<const int>(12);
  });
  EXPECT_EQ(made, 1);
  EXPECT_EQ(*again, 12);
}

TEST(SharedCache, AFailedMakeReachesItsCallerAndTheNextCallerMakesAgain) {
  SharedCache<int, int> cache;
  EXPECT_THROW(
      cache.Get(1, []() -> std::shared_ptr<const int> { throw std::runtime_error("no model"); }),
      std::runtime_error);
  EXPECT_EQ(*cache.Get(1, [] { return std::make_shared<const int>(3); }), 3);
}

// Two sensors of one model opened at once: the second waits for the first one's value instead of
// making a second copy. The first make holds on until the second caller has asked and a while
// more: a cache that let the second caller make its own would make it in that while; a correct
// one keeps it waiting, so the wait runs out (it bounds the test, nothing is timed).
TEST(SharedCache, CallersOfOneKeyAtOnceWaitForOneValue) {
  SharedCache<int, int> cache;
  std::mutex mutex;
  std::condition_variable changed;
  int made = 0;
  std::promise<void> making;
  std::shared_ptr<const int> first;
  std::thread first_caller([&] {
    first = cache.Get(1, [&] {
      {
        const std::lock_guard<std::mutex> lock(mutex);
        ++made;
      }
      making.set_value();
      std::unique_lock<std::mutex> lock(mutex);
      changed.wait_for(lock, std::chrono::milliseconds(300), [&] { return made > 1; });
      return std::make_shared<const int>(1);
    });
  });
  making.get_future().wait();
  const std::shared_ptr<const int> second = cache.Get(1, [&] {
    {
      const std::lock_guard<std::mutex> lock(mutex);
      ++made;
    }
    changed.notify_all();
    return std::make_shared<const int>(2);
  });
  first_caller.join();
  EXPECT_EQ(made, 1);
  EXPECT_EQ(first, second);
  EXPECT_EQ(*second, 1);
}

// While one key's value is being made (a model built for minutes), another key's callers go on.
TEST(SharedCache, AnotherKeyIsNotHeldUpWhileOneIsMade) {
  SharedCache<int, int> cache;
  std::promise<void> making;
  std::promise<void> other_done;
  bool other_done_first = false;
  std::thread first_caller([&] {
    cache.Get(1, [&] {
      making.set_value();
      // Bounds the test if the cache held every key while making one (then this fails).
      other_done_first =
          other_done.get_future().wait_for(std::chrono::seconds(60)) == std::future_status::ready;
      return std::make_shared<const int>(1);
    });
  });
  making.get_future().wait();
  EXPECT_EQ(*cache.Get(2, [] { return std::make_shared<const int>(2); }), 2);
  other_done.set_value();
  first_caller.join();
  EXPECT_TRUE(other_done_first);
}

}  // namespace
}  // namespace tac3d
