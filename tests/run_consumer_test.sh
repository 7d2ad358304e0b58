#!/usr/bin/env bash
# Installs tac3d from BUILD_DIR into a temporary prefix, builds tests/consumer against it with
# default flags (no -march), and runs it. Usage: run_consumer_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
source_dir=$1
build_dir=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
# Only the public headers are installed: no test helpers, no internal readers.
for internal in force/test_loads.h sensor/yaml_reader.h testing/testing.h protocol/udp_socket.h; do
  if [ -e "$work/prefix/include/tac3d/$internal" ]; then
    echo "an internal header was installed: include/tac3d/$internal" >&2
    exit 1
  fi
done
env -u CXXFLAGS -u CFLAGS cmake -S "$source_dir/tests/consumer" -B "$work/build" \
  -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE= > "$work/configure.log"
cmake --build "$work/build" > "$work/build.log"
flags=$(grep -h "CXX_FLAGS" "$work/build/CMakeFiles/consumer.dir/flags.make" || true)
echo "consumer compiled with: $flags"
if echo "$flags" | grep -q -- "-march"; then
  echo "the consumer was compiled with -march: not a default-flags consumer" >&2
  exit 1
fi
"$work/build/consumer"
