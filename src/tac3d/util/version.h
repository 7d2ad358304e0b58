#pragma once

namespace tac3d {

/// The project's version, CMake's project(VERSION) (top-level CMakeLists.txt, the one place it
/// is set): `tac3d --version`, tac3d.__version__, the Python package's metadata (setup.py reads
/// the same line) and the model caches' code version.
const char* Version();

}  // namespace tac3d
