#pragma once

namespace tac3d::testing {

/// Whether MallocCalls() counts: false under AddressSanitizer, which owns malloc.
bool MallocIsCounted();

/// The number of malloc calls in this process so far. Linking tac3d_malloc_counter
/// interposes malloc to count them; a no-allocation test compares two readings.
long MallocCalls();

}  // namespace tac3d::testing
