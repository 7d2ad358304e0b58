#pragma once

#include <string>

namespace tac3d::python {

/// `dir` if not empty, else $TAC3D_CACHE_DIR, $XDG_CACHE_HOME/tac3d, $HOME/.cache/tac3d, as
/// the CLI; the folder is created. @throws tac3d::Error if it cannot be.
std::string ResolveCacheDir(const std::string& dir);

}  // namespace tac3d::python
