#!/usr/bin/env bash
# Installs tac3d's build dependencies from Debian 12's packages (idempotent), then
# configures and builds into ${BUILD_DIR:-build}. Used by scripts/demo.sh and scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake g++ make ninja-build pkg-config
  libopencv-dev libeigen3-dev libsuitesparse-dev libopenblas-dev
  libjpeg62-turbo-dev  # libjpeg-turbo: a camera's MJPEG decoded partially (src/tac3d/imagefile)
  libyaml-cpp-dev nlohmann-json3-dev libfmt-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopen3d-dev
  cyclonedds-dev cyclonedds-tools  # tac3d run --ros2 (src/tac3d/ros2): Cyclone DDS and its idlc
  libfastrtps-dev libfastcdr-dev fastddsgen  # the ROS 2 interop test's subscriber (tests/ros2_interop); fastddsgen brings a JRE
  libboost-dev  # Boost.Beast (header-only), the viewer's HTTP + WebSocket server (src/tac3d/web)
  libjs-three   # three.js r111, copied into the build's page folder (docs/viewer.md)
  chromium      # web/viewer_page_test loads the page headless
  python3-numpy  # io/recording_export_test loads the exported .npy files with numpy
  python3-dev pybind11-dev python3-pybind11  # the Python module (python/)
  python3-pytest python3-yaml python3-matplotlib  # its tests (python/tests), examples/python
  python3-distributed python3-zarr  # tac3d.datasets: episodes on Dask, stored as zarr
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# The MCAP export's test reads the files with Foxglove's libraries from npm (tests/mcap_oracle);
# a Node.js from elsewhere (NodeSource) brings its own npm, and Debian's would conflict with it.
command -v npm >/dev/null || missing+=(nodejs npm)
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

build_dir=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc)}
# A new build folder gets Ninja (it starts a target's compiles before the targets it links are
# done, which keeps both cores busy); an existing one keeps its generator, as does a
# CMAKE_GENERATOR set by the caller.
generator=()
if [ ! -f "$build_dir/CMakeCache.txt" ] && [ -z "${CMAKE_GENERATOR:-}" ]; then
  generator=(-G Ninja)
fi
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j "$jobs"
