#include "tac3d/testing/malloc_counter.h"

#include <atomic>
#include <cstddef>

namespace {
std::atomic<long> g_malloc_calls{0};
}  // namespace

#if defined(__SANITIZE_ADDRESS__)
namespace tac3d::testing {
bool MallocIsCounted() { return false; }
}  // namespace tac3d::testing
#else
extern "C" void* __libc_malloc(std::size_t size);
extern "C" void* malloc(std::size_t size) {
  g_malloc_calls.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
namespace tac3d::testing {
bool MallocIsCounted() { return true; }
}  // namespace tac3d::testing
#endif

namespace tac3d::testing {
long MallocCalls() { return g_malloc_calls.load(std::memory_order_relaxed); }
}  // namespace tac3d::testing
