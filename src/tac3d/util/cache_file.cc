#include "tac3d/util/cache_file.h"

#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string_view>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

static_assert(std::endian::native == std::endian::little, "cache files are little-endian");

// Appends a trivially copyable value's bytes.
template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Reads sequentially from a byte buffer, throwing on truncation.
class Reader {
 public:
  Reader(std::string_view bytes, const std::string& path) : bytes_(bytes), path_(path) {}

  template <typename T>
  T Get(const char* what) {
    T value;
    std::memcpy(&value, Take(sizeof(T), what), sizeof(T));
    return value;
  }
  const char* Take(size_t size, const char* what) {
    if (size > bytes_.size() - offset_) {
      throw Error(fmt::format("{}: truncated while reading {} ({} bytes at offset {}, file has {})",
                              path_,
                              what,
                              size,
                              offset_,
                              bytes_.size()));
    }
    const char* p = bytes_.data() + offset_;
    offset_ += size;
    return p;
  }
  size_t offset() const { return offset_; }
  size_t remaining() const { return bytes_.size() - offset_; }

 private:
  std::string_view bytes_;
  const std::string& path_;
  size_t offset_ = 0;
};

// A cache file's content, its matrices left where they are in `bytes`.
struct ParsedRecord {
  std::uint64_t key = 0;
  nlohmann::json header;
  struct Matrix {
    Eigen::Index rows = 0;
    Eigen::Index cols = 0;
    const char* data = nullptr;  ///< rows * cols f64, column-major, maybe unaligned
  };
  std::vector<Matrix> matrices;
};

// Checks and parses a cache file's bytes (WriteCacheRecord's format).
ParsedRecord ParseCacheRecord(std::string_view bytes,
                              const std::string& path,
                              const std::string& magic,
                              std::uint32_t format_version) {
  TAC3D_DEMAND(magic.size() == 8);
  Reader reader(bytes, path);
  if (std::memcmp(reader.Take(8, "the magic"), magic.data(), 8) != 0) {
    throw Error(fmt::format("{}: not a {} file (wrong magic)", path, magic));
  }
  const size_t body_begin = reader.offset();
  const auto version = reader.Get<std::uint32_t>("the format version");
  if (version != format_version) {
    throw Error(fmt::format("{}: format version {}, expected {}", path, version, format_version));
  }
  ParsedRecord record;
  record.key = reader.Get<std::uint64_t>("the key");
  const auto json_size = reader.Get<std::uint64_t>("the JSON length");
  const char* json_text = reader.Take(json_size, "the JSON header");
  // Matrices until only the checksum is left.
  while (reader.remaining() > sizeof(std::uint64_t)) {
    const auto rows = reader.Get<std::uint64_t>("a row count");
    const auto cols = reader.Get<std::uint64_t>("a column count");
    if (rows > (1u << 24) || cols > (1u << 24) ||
        rows * cols > reader.remaining() / sizeof(double)) {
      throw Error(fmt::format("{}: implausible matrix size {} x {}", path, rows, cols));
    }
    record.matrices.push_back({static_cast<Eigen::Index>(rows),
                               static_cast<Eigen::Index>(cols),
                               reader.Take(rows * cols * sizeof(double), "a matrix")});
  }
  const size_t body_end = reader.offset();
  const auto checksum = reader.Get<std::uint64_t>("the checksum");
  if (reader.offset() != bytes.size()) {
    throw Error(
        fmt::format("{}: {} bytes after the checksum", path, bytes.size() - reader.offset()));
  }
  if (Fnv1a(bytes.data() + body_begin, body_end - body_begin) != checksum) {
    throw Error(fmt::format("{}: checksum mismatch (the file is corrupt)", path));
  }
  try {
    record.header = nlohmann::json::parse(json_text, json_text + json_size);
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: invalid JSON header: {}", path, e.what()));
  }
  return record;
}

}  // namespace

std::uint64_t Fnv1a(const void* data, size_t size, std::uint64_t hash) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 1099511628211ULL;
  }
  return hash;
}

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

void WriteCacheRecord(const std::string& path,
                      const std::string& magic,
                      std::uint32_t format_version,
                      const CacheRecord& record) {
  TAC3D_DEMAND(magic.size() == 8);
  const std::string json = record.header.dump();
  std::string body;  // everything after the magic, which the checksum covers
  Put(&body, format_version);
  Put(&body, record.key);
  Put(&body, static_cast<std::uint64_t>(json.size()));
  body += json;
  for (const Eigen::MatrixXd& m : record.matrices) {
    Put(&body, static_cast<std::uint64_t>(m.rows()));
    Put(&body, static_cast<std::uint64_t>(m.cols()));
    body.append(reinterpret_cast<const char*>(m.data()), m.size() * sizeof(double));
  }
  const std::uint64_t checksum = Fnv1a(body.data(), body.size());

  WriteFileAtomically(path, [&](const std::string& temporary) {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(magic.data(), 8);
    out.write(body.data(), static_cast<std::streamsize>(body.size()));
    out.write(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
    out.flush();
    if (!out) throw Error(fmt::format("cannot write the cache file {}", temporary));
  });
}

CacheRecord ReadCacheRecord(const std::string& path,
                            const std::string& magic,
                            std::uint32_t format_version) {
  RequireRegularFile(path, "cache file");  // a FIFO planted in the cache would block the open
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open", path));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ParsedRecord parsed = ParseCacheRecord(bytes, path, magic, format_version);
  CacheRecord record;
  record.key = parsed.key;
  record.header = std::move(parsed.header);
  for (const ParsedRecord::Matrix& m : parsed.matrices) {
    Eigen::MatrixXd& copy = record.matrices.emplace_back(m.rows, m.cols);
    std::memcpy(copy.data(), m.data, copy.size() * sizeof(double));
  }
  return record;
}

MappedCacheRecord MapCacheRecord(const std::string& path,
                                 const std::string& magic,
                                 std::uint32_t format_version) {
  RequireRegularFile(path, "cache file");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(fmt::format("{}: cannot open", path));
  struct stat info {};
  if (::fstat(fd, &info) != 0 || info.st_size == 0) {
    ::close(fd);
    throw Error(fmt::format("{}: cannot read its size, or it is empty", path));
  }
  const auto size = static_cast<size_t>(info.st_size);
  void* address = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);  // the mapping keeps the file
  if (address == MAP_FAILED) throw Error(fmt::format("{}: cannot map it", path));
  std::shared_ptr<const void> mapping(address, [size](const void* p) {
    ::munmap(const_cast<void*>(p), size);
  });
  ParsedRecord parsed = ParseCacheRecord(
      std::string_view(static_cast<const char*>(address), size), path, magic, format_version);
  MappedCacheRecord record;
  record.key = parsed.key;
  record.header = std::move(parsed.header);
  record.mapping = std::move(mapping);
  for (const ParsedRecord::Matrix& m : parsed.matrices) {
    record.matrices.push_back({reinterpret_cast<const double*>(m.data), m.rows, m.cols});
  }
  return record;
}

const char* Describe(CacheStatus status) {
  switch (status) {
    case CacheStatus::kLoaded: return "loaded from the cache";
    case CacheStatus::kBuiltMissing: return "built (not cached yet)";
    case CacheStatus::kRebuiltStale: return "rebuilt (the cached file was stale)";
    case CacheStatus::kRebuiltCorrupt: return "rebuilt (the cached file was corrupt)";
  }
  return "?";
}

std::string CacheFilePath(const std::string& cache_dir, std::string_view kind, std::uint64_t key) {
  return (std::filesystem::path(cache_dir) / fmt::format("{}_{:016x}.bin", kind, key)).string();
}

CacheBuildLock::CacheBuildLock(const std::string& path) {
  const std::string lock_path = path + ".lock";
  fd_ = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0666);
  if (fd_ < 0) return;
  if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
  waited_ = true;
  std::fprintf(stderr, "tac3d: another process is building %s; waiting for it to finish\n", path.c_str());
  while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
  }
}

CacheBuildLock::~CacheBuildLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

}  // namespace tac3d
