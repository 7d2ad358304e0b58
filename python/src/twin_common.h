#pragma once

#include <string>

namespace tac3d::python {

/// `dir` if not empty, else DefaultCacheDir(), made with MakeCacheDirectory as the CLI's
/// --cache is (util/file_io.h). @throws tac3d::Error if it cannot be.
std::string ResolveCacheDir(const std::string& dir);

}  // namespace tac3d::python
