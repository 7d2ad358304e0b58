#!/usr/bin/env bash
# Builds tac3d and runs every test (not the heavy accuracy runs labelled `eval`:
# scripts/eval.sh runs those).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
status=0
ctest --test-dir "$build_dir" --output-on-failure -j "${JOBS:-$(nproc)}" -LE eval || status=$?
# The Python suite runs as one CTest test (python/pytest); print pytest's own count of tests.
log="$build_dir/Testing/Temporary/LastTest.log"
if [ -f "$log" ]; then
  grep -h -E "^=* ?[0-9]+ (passed|failed|error)" "$log" | sed 's/^/python tests (pytest): /' || true
fi
exit "$status"
