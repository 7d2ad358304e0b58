#!/usr/bin/env bash
# Builds tac3d and runs every test (not the heavy accuracy runs labelled `eval`:
# scripts/eval.sh runs those).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
ctest --test-dir "$build_dir" --output-on-failure -j "${JOBS:-$(nproc)}" -LE eval
