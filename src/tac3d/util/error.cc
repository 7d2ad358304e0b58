#include "tac3d/util/error.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace tac3d {

void OptionCheck::operator()(bool ok, const char* field, const char* bound, double value) const {
  if (!ok || std::isnan(value)) {
    throw Error(fmt::format("{}: {} = {} must be {}", what_, field, value, bound));
  }
}

}  // namespace tac3d

namespace tac3d::internal {

void DemandFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "tac3d: internal invariant failed: %s at %s:%d\n", condition, file,
               line);
  std::abort();
}

}  // namespace tac3d::internal
