#pragma once

#include <cstddef>
#include <cstdio>
#include <functional>
#include <initializer_list>
#include <string>
#include <string_view>

namespace tac3d {

/// Size cap of a text file tac3d reads as a whole (a sensor config, a scene, a board): far
/// above any real one (the prototype's sensor YAML is ~3 kB), so /dev/zero or a wrong file
/// fails at once instead of filling memory.
inline constexpr std::size_t kMaxConfigFileBytes = 4u << 20;

/// Reads a whole regular file of at most `max_bytes`.
/// @param what what the file is for the messages ("sensor config").
/// @throws Error naming the file when it does not exist, is a directory or not a regular
///   file (a device, a pipe), cannot be read, or is larger than max_bytes.
std::string ReadFileCapped(const std::string& path, std::size_t max_bytes, std::string_view what);

/// Checks, before any work, that an output file can be created: its folder exists and is a
/// folder, the path is not a folder, and (if `extensions` is not empty) it ends in one of them
/// (".png"; compared case-insensitively). @throws Error naming the path and the problem.
void CheckOutputFile(const std::string& path,
                     std::string_view what,
                     std::initializer_list<std::string_view> extensions = {});

/// Checks, before any work, that an output folder can be made or used: the path is not a file,
/// and the folder it goes in exists and is writable (so a typo in a parent is refused, not
/// created). @throws Error naming the path and the problem.
void CheckOutputFolder(const std::string& path, std::string_view what);

/// Where compliance and twin models are cached unless told otherwise: $TAC3D_CACHE_DIR, else
/// $XDG_CACHE_HOME/tac3d, else $HOME/.cache/tac3d, else .tac3d-cache. The CLI's `--cache`
/// default and the Python module's `cache_dir=''`.
std::string DefaultCacheDir();

/// Makes the model cache folder `dir` if it is missing: DefaultCacheDir() with its parents
/// (~/.cache may not exist yet), any other folder only where CheckOutputFolder allows.
/// @throws Error naming the folder if it cannot be made.
void MakeCacheDirectory(const std::string& dir);

/// Writes a file through a temporary name in the same folder and renames it, so the final
/// name only ever holds a whole file. `write` writes to the temporary path it is given and
/// throws on failure; the temporary is removed if it or the rename fails.
/// @throws Error naming the file.
void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string&)>& write);

/// WriteFileAtomically with the bytes of `content`.
void WriteTextFileAtomically(const std::string& path, std::string_view content);

/// Writes `line` and a newline to `out` and flushes it, so a reader at the other end of a
/// pipe gets each line as it is written (stdout on a pipe is block-buffered), and a killed
/// process has lost none of the lines it wrote. @throws Error if the write fails.
void WriteLineFlushed(std::FILE* out, std::string_view line);

/// Creates a directory (and its parents). @throws Error naming it if it cannot.
void MakeDirectory(const std::string& path);

}  // namespace tac3d
