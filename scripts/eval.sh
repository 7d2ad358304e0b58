#!/usr/bin/env bash
# Builds tac3d and runs the long accuracy evaluations (ctest label `eval`).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
ctest --test-dir "$build_dir" --output-on-failure -L eval
