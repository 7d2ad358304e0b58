#!/usr/bin/env bash
# Builds tac3d and runs every test (not the heavy accuracy runs labelled `eval`:
# scripts/eval.sh runs those).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
# Every run starts from an empty model cache of its own, as on a fresh machine: no test can
# depend on (or fill) the user's ~/.cache/tac3d, and one that needs a model builds a small one.
cache_dir=$(mktemp -d -t tac3d-test-cache.XXXXXX)
trap 'rm -rf "$cache_dir"' EXIT
export TAC3D_CACHE_DIR=$cache_dir XDG_CACHE_HOME=$cache_dir
status=0
ctest --test-dir "$build_dir" --output-on-failure -j "${JOBS:-$(nproc)}" -LE eval || status=$?
# The Python suite runs as one CTest test (python/pytest); print pytest's own count of tests.
log="$build_dir/Testing/Temporary/LastTest.log"
if [ -f "$log" ]; then
  grep -h -E "^=* ?[0-9]+ (passed|failed|error)" "$log" | sed 's/^/python tests (pytest): /' || true
fi
exit "$status"
