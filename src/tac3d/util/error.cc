#include "tac3d/util/error.h"

#include <cstdio>
#include <cstdlib>

namespace tac3d::internal {

void DemandFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "tac3d: internal invariant failed: %s at %s:%d\n", condition, file,
               line);
  std::abort();
}

}  // namespace tac3d::internal
