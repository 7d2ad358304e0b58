#include "tac3d/util/file_io.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "tac3d/util/error.h"

namespace tac3d {
namespace fs = std::filesystem;

std::uintmax_t RequireRegularFile(const std::string& path, std::string_view what) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) {
    throw Error(fmt::format("{} '{}' cannot be opened: {}", what, path, ec.message()));  // a link loop
  }
  if (!fs::exists(status)) throw Error(fmt::format("{} '{}' does not exist", what, path));
  if (fs::is_directory(status))
    throw Error(fmt::format("{} '{}' is a directory, not a file", what, path));
  if (!fs::is_regular_file(status)) {
    throw Error(fmt::format("{} '{}' is not a regular file (a device or a pipe?)", what, path));
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw Error(fmt::format("{} '{}': {}", what, path, ec.message()));
  return size;
}

std::string ReadFileCapped(const std::string& path, std::size_t max_bytes, std::string_view what) {
  const std::uintmax_t size = RequireRegularFile(path, what);
  if (size > max_bytes) {
    throw Error(fmt::format(
        "{} '{}' is {} bytes, more than the limit of {} bytes", what, path, size, max_bytes));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{} '{}' cannot be opened", what, path));
  // Read at most one byte past the cap, in case the file grew since its size was taken; in
  // chunks, so a small file under a large cap costs its size, not the cap's.
  std::string text;
  text.reserve(static_cast<std::size_t>(std::min<std::uintmax_t>(size, max_bytes)) + 1);
  char chunk[1 << 16];
  while (in && text.size() <= max_bytes) {
    in.read(chunk, static_cast<std::streamsize>(std::min(sizeof(chunk), max_bytes + 1 - text.size())));
    text.append(chunk, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw Error(fmt::format("{} '{}' cannot be read", what, path));
  if (text.size() > max_bytes) {
    throw Error(fmt::format("{} '{}' is larger than the limit of {} bytes", what, path, max_bytes));
  }
  return text;
}

namespace {

// The folder `path` goes in exists and is writable.
void CheckParentFolder(const fs::path& path, std::string_view what) {
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(parent, ec)) {
    throw Error(fmt::format(
        "{} '{}': the folder '{}' does not exist", what, path.string(), parent.string()));
  }
  if (::access(parent.c_str(), W_OK) != 0) {
    throw Error(fmt::format(
        "{} '{}': the folder '{}' is not writable", what, path.string(), parent.string()));
  }
}

// Refuses an output that is one of `inputs` or would replace a file inside an input folder.
void CheckNotAnInput(const fs::path& path,
                     std::string_view what,
                     const std::vector<std::string>& inputs) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return;  // a new file replaces nothing
  const fs::path output = fs::canonical(path, ec);
  if (ec) return;
  for (const std::string& input : inputs) {
    std::error_code input_ec;
    if (input.empty() || !fs::exists(input, input_ec)) continue;
    if (fs::equivalent(path, input, input_ec)) {
      throw Error(fmt::format(
          "{} '{}' is the input '{}': write the output elsewhere", what, path.string(), input));
    }
    if (!fs::is_directory(input, input_ec)) continue;
    const fs::path folder = fs::canonical(input, input_ec);
    if (input_ec) continue;
    const auto [folder_end, unused] =
        std::mismatch(folder.begin(), folder.end(), output.begin(), output.end());
    if (folder_end == folder.end()) {
      throw Error(fmt::format("{} '{}' would replace a file inside the input folder '{}': write "
                              "the output elsewhere",
                              what,
                              path.string(),
                              input));
    }
  }
}

}  // namespace

void CheckOutputFile(const std::string& path,
                     std::string_view what,
                     std::initializer_list<std::string_view> extensions,
                     const std::vector<std::string>& inputs) {
  if (path.empty()) throw Error(fmt::format("{}: empty output path", what));
  const fs::path p(path);
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(p, ec);
  if (!ec && fs::is_symlink(status)) {
    throw Error(fmt::format(
        "{} '{}' is a symbolic link: name the file itself (tac3d replaces only regular files)",
        what,
        path));
  }
  if (!ec && fs::is_directory(status))
    throw Error(fmt::format("{} '{}' is a directory", what, path));
  if (!ec && fs::exists(status) && !fs::is_regular_file(status)) {
    throw Error(fmt::format(
        "{} '{}' is not a regular file (a device or a pipe?): tac3d writes only regular files",
        what,
        path));
  }
  if (extensions.size() > 0) {
    std::string ext = p.extension().string();
    std::transform(
        ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
      std::string allowed;
      for (std::string_view e : extensions)
        allowed += fmt::format("{}{}", allowed.empty() ? "" : ", ", e);
      throw Error(fmt::format("{} '{}' must end in {}", what, path, allowed));
    }
  }
  CheckParentFolder(p, what);
  CheckNotAnInput(p, what, inputs);
}

void CheckOutputFolder(const std::string& path, std::string_view what) {
  if (path.empty()) throw Error(fmt::format("{}: empty output path", what));
  std::error_code ec;
  if (fs::exists(path, ec) && !fs::is_directory(path, ec)) {
    throw Error(fmt::format("{} '{}' is a file, not a folder", what, path));
  }
  fs::path folder = fs::path(path).lexically_normal();
  if (!folder.has_filename()) folder = folder.parent_path();  // "a/b/" is the folder a/b
  CheckParentFolder(folder, what);
}

std::string DefaultCacheDir() {
  if (const char* dir = std::getenv("TAC3D_CACHE_DIR"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/tac3d";
  if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/tac3d";
  return ".tac3d-cache";
}

void MakeCacheDirectory(const std::string& dir) {
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return;
  if (dir != DefaultCacheDir()) CheckOutputFolder(dir, "cache folder");
  fs::create_directories(dir, ec);
  if (ec) throw Error(fmt::format("cannot create the cache folder '{}': {}", dir, ec.message()));
}

std::string CreateTemporaryFile(const std::string& path) {
  // Unique within the process (threads write beside one another) and across processes (pid);
  // O_EXCL refuses any name that exists, a planted symbolic link included.
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0; attempt < 100; ++attempt) {
    const std::string temporary = fmt::format("{}.tmp{}-{}", path, ::getpid(), counter++);
    const int fd =
        ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd >= 0) {
      ::close(fd);
      return temporary;
    }
    if (errno != EEXIST) {
      throw Error(fmt::format(
          "cannot create a temporary file beside '{}': {}", path, std::strerror(errno)));
    }
  }
  throw Error(fmt::format("cannot create a temporary file beside '{}': 100 names taken", path));
}

void ReplaceWithTemporary(const std::string& temporary, const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(path, ec);
  if (!ec && fs::exists(status) && !fs::is_regular_file(status)) {
    throw Error(fmt::format(
        "'{}' exists and is not a regular file (a device, a pipe, a folder or a symbolic link): "
        "tac3d does not replace it",
        path));
  }
  fs::rename(temporary, path, ec);
  if (ec) throw Error(fmt::format("cannot rename '{}' to '{}': {}", temporary, path, ec.message()));
}

void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string&)>& write) {
  const std::string temporary = CreateTemporaryFile(path);
  try {
    write(temporary);
    ReplaceWithTemporary(temporary, path);
  } catch (...) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw;
  }
}

void WriteTextFileAtomically(const std::string& path, std::string_view content) {
  WriteFileAtomically(path, [&](const std::string& temporary) {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) throw Error(fmt::format("cannot write '{}'", path));
  });
}

void WriteLineFlushed(std::FILE* out, std::string_view line) {
  if (std::fwrite(line.data(), 1, line.size(), out) != line.size() ||
      std::fputc('\n', out) == EOF || std::fflush(out) != 0) {
    throw Error("cannot write a line to the output (closed pipe?)");
  }
}

void MakeDirectory(const std::string& path) {
  std::error_code ec;
  fs::create_directories(path, ec);
  if (ec) throw Error(fmt::format("cannot create directory '{}': {}", path, ec.message()));
}

}  // namespace tac3d
