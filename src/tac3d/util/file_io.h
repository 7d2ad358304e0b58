#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace tac3d {

/// Size cap of a text file tac3d reads as a whole (a sensor config, a scene, a board): far
/// above any real one (the prototype's sensor YAML is ~3 kB), so /dev/zero or a wrong file
/// fails at once instead of filling memory.
inline constexpr std::size_t kMaxConfigFileBytes = 4u << 20;

/// Checks that `path` is a regular file (following links) before anything reads it: /dev/zero
/// never ends, a FIFO blocks for ever. @returns its size in bytes.
/// @param what what the file is for the messages ("PLY file").
/// @throws Error naming the file when it does not exist, is a directory or is not a regular
///   file (a device, a pipe).
std::uintmax_t RequireRegularFile(const std::string& path, std::string_view what);

/// Reads a whole regular file of at most `max_bytes`.
/// @param what what the file is for the messages ("sensor config").
/// @throws Error naming the file when it does not exist, is a directory or not a regular
///   file (a device, a pipe), cannot be read, or is larger than max_bytes.
std::string ReadFileCapped(const std::string& path, std::size_t max_bytes, std::string_view what);

/// The one rule for every file tac3d writes, checked before any work: the path is not empty
/// and not a folder; if it exists it is a regular file (not a device, a pipe or a symbolic
/// link, which a write would replace or write through); it is none of `inputs` and does not
/// replace a file inside an input folder (so `--out` never destroys what the command reads);
/// its folder exists and is writable; and (if `extensions` is not empty) it ends in one of them
/// (".png"; compared case-insensitively).
/// @param inputs the files and folders the command reads (missing ones are skipped).
/// @throws Error naming the path and the problem.
void CheckOutputFile(const std::string& path,
                     std::string_view what,
                     std::initializer_list<std::string_view> extensions = {},
                     const std::vector<std::string>& inputs = {});

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

/// Creates an empty temporary file beside `path` (in the same folder, so it can be renamed
/// over it) under a name no other file has, exclusively: a file or a symbolic link planted at
/// a predictable temporary name is never opened or written through. @returns its path.
/// @throws Error naming `path` if it cannot be created.
std::string CreateTemporaryFile(const std::string& path);

/// Renames the temporary `temporary` over `path`, unless `path` exists and is not a regular
/// file (a device, a pipe, a symbolic link): those are refused, never replaced.
/// @throws Error naming the file; the temporary is left for the caller to remove.
void ReplaceWithTemporary(const std::string& temporary, const std::string& path);

/// Writes a file through a temporary (CreateTemporaryFile) and renames it into place
/// (ReplaceWithTemporary), so the final name only ever holds a whole file. `write` writes to
/// the temporary path it is given and throws on failure; the temporary is removed if it or the
/// rename fails. @throws Error naming the file.
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
