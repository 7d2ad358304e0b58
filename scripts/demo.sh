#!/usr/bin/env bash
# Builds tac3d and runs the demo on the built-in digital twin (no hardware needed).
# Output goes to ${OUT:-out/demo}.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
"$build_dir/bin/tac3d" demo --out "${OUT:-out/demo}" "$@"
