#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "tac3d/util/error.h"
#include "tac3d/util/shared_cache.h"

namespace tac3d {

/// 64-bit FNV-1a hash of a byte range, continuing from `hash`.
std::uint64_t Fnv1a(const void* data, size_t size, std::uint64_t hash = 14695981039346656037ULL);

/// The current time, UTC, ISO 8601 ("2024-05-01T12:00:00Z").
std::string UtcNow();

/// The content of a cache file: a key (a hash of every input it was built from), a JSON
/// header (the inputs and the provenance) and dense matrices.
struct CacheRecord {
  std::uint64_t key = 0;
  nlohmann::json header;
  std::vector<Eigen::MatrixXd> matrices;
};

/// Writes a cache file, to a temporary name then renamed, so a crash never leaves a
/// half-written file under the final name. Format (little-endian): the 8-byte magic,
/// u32 format version, u64 key, u64 JSON length, the JSON, then per matrix u64 rows,
/// u64 cols and rows * cols f64 (column-major), then a u64 FNV-1a checksum of every byte
/// after the magic.
/// @param magic exactly 8 characters.
/// @throws tac3d::Error if the file cannot be written.
void WriteCacheRecord(const std::string& path,
                      const std::string& magic,
                      std::uint32_t format_version,
                      const CacheRecord& record);

/// Reads a file written by WriteCacheRecord and checks its structure and checksum; the key is
/// returned, not judged (the caller compares it with the key of its inputs).
/// @throws tac3d::Error naming the file if it is missing, has another magic or format
///   version, is truncated or too long, fails its checksum, or its JSON does not parse.
CacheRecord ReadCacheRecord(const std::string& path,
                            const std::string& magic,
                            std::uint32_t format_version);

/// A matrix of a mapped cache file: its f64 where they are in the file (column-major, maybe
/// unaligned), valid while the mapping lives.
struct MappedMatrix {
  const double* data = nullptr;
  Eigen::Index rows = 0;
  Eigen::Index cols = 0;
};

/// A cache file mapped read-only (mmap, MAP_SHARED): its matrices are the file's pages, which
/// every process mapping the same file shares (the page cache) instead of each holding a copy.
struct MappedCacheRecord {
  std::uint64_t key = 0;
  nlohmann::json header;
  std::vector<MappedMatrix> matrices;
  /// Unmaps the file when the last copy goes.
  std::shared_ptr<const void> mapping;
};

/// ReadCacheRecord's checks (every page is read once, for the checksum), the matrices left
/// mapped. A cache file is replaced by renaming a new one over it, never written in place, so
/// a mapping keeps the file it mapped. @throws tac3d::Error as ReadCacheRecord, or if the file
/// cannot be mapped.
MappedCacheRecord MapCacheRecord(const std::string& path,
                                 const std::string& magic,
                                 std::uint32_t format_version);

/// What a load-or-build did with its cache file.
enum class CacheStatus {
  kLoaded,          ///< the cached file was valid and used
  kBuiltMissing,    ///< no cached file: built and saved
  kRebuiltStale,    ///< the file was for other inputs or code: rebuilt and overwritten
  kRebuiltCorrupt,  ///< the file was unreadable, truncated or failed its checksum: rebuilt
};

/// A phrase for messages: "loaded from the cache", "built (not cached yet)", ...
const char* Describe(CacheStatus status);

/// The cache file of a model of `kind` ("compliance", "twin_body") and `key` in cache_dir:
/// cache_dir/<kind>_<key as 16 hex digits>.bin.
std::string CacheFilePath(const std::string& cache_dir, std::string_view kind, std::uint64_t key);

/// How a caller of a process-wide model cache (fem::LoadSharedComplianceModel,
/// simulation::LoadSharedTwinBodyModel) got its model, for a report of where it came from.
struct SharedModelSource {
  /// The model's cache file in the caller's cache folder.
  std::string path;
  /// What this call's load-or-build did; nullopt: another holder had the model in memory, so
  /// no file was read.
  std::optional<CacheStatus> status;
  /// Wall time of this call's load or build (s); 0 when in memory.
  double elapsed_s = 0.0;
};

/// The model of `key`, one copy for the whole process (SharedCache: kept while anyone holds it):
/// the one alive, else load()'s, a load-or-build result (members model, status, elapsed_s).
/// @param source if given, set to `path` (the model's cache file) and how this call got it.
template <typename Model, typename Load>
std::shared_ptr<const Model> GetSharedModel(SharedCache<std::uint64_t, Model>& models,
                                            std::uint64_t key,
                                            const std::string& path,
                                            const Load& load,
                                            SharedModelSource* source) {
  SharedModelSource got;
  got.path = path;
  std::shared_ptr<const Model> model = models.Get(key, [&] {
    auto cached = load();
    got.status = cached.status;
    got.elapsed_s = cached.elapsed_s;
    return std::make_shared<const Model>(std::move(cached.model));
  });
  if (source) *source = std::move(got);
  return model;
}

/// An exclusive lock on building the cache file `path` (a flock on `path`.lock, released when
/// this goes): a second process (or thread) that needs the same model waits for the first to
/// finish building it, saying so on stderr, instead of building it too (minutes and gigabytes).
/// Where the lock file cannot be made (a read-only folder), nothing is locked.
class CacheBuildLock {
 public:
  explicit CacheBuildLock(const std::string& path);
  ~CacheBuildLock();
  CacheBuildLock(const CacheBuildLock&) = delete;
  CacheBuildLock& operator=(const CacheBuildLock&) = delete;
  /// Whether another holder had it, so the file may have been built meanwhile.
  bool waited() const { return waited_; }

 private:
  int fd_ = -1;
  bool waited_ = false;
};

/// The policy of every cached model: the file at `path` is used only if it reads back whole and
/// its key is `key`; otherwise the model is built and saved over it (its folder created), so a
/// stale or corrupt file is never used. The build holds a CacheBuildLock: a process that waited
/// for another's build loads what it saved.
/// @param read read(path) returns an object with members `key` and `model`; it throws
///   tac3d::Error if the file is unreadable, truncated or fails its checksum.
/// @param build build() returns the model; save(model, path) writes it.
/// @param reason set to why the file was not used (empty when loaded).
/// @throws tac3d::Error if the folder cannot be created, or as build and save do.
template <typename Model, typename Read, typename Build, typename Save>
CacheStatus LoadOrBuildCacheFile(const std::string& path,
                                 std::uint64_t key,
                                 const Read& read,
                                 const Build& build,
                                 const Save& save,
                                 Model* model,
                                 std::string* reason) {
  CacheStatus status = CacheStatus::kBuiltMissing;
  // Loads the file if it is there, whole and of this key; else says why not.
  const auto load = [&]() -> bool {
    reason->clear();
    if (!std::filesystem::exists(path)) return false;
    try {
      auto cached = read(path);
      if (cached.key == key) {
        *model = std::move(cached.model);
        return true;
      }
      status = CacheStatus::kRebuiltStale;
      *reason = fmt::format("key {:016x}, expected {:016x} (other inputs or code)", cached.key, key);
    } catch (const Error& e) {
      status = CacheStatus::kRebuiltCorrupt;
      *reason = e.what();
    }
    return false;
  };
  if (load()) return CacheStatus::kLoaded;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (!folder.empty()) std::filesystem::create_directories(folder, error);
  if (error) throw Error(fmt::format("cannot create the cache directory {}", folder.string()));
  const CacheBuildLock lock(path);
  if (lock.waited() && load()) return CacheStatus::kLoaded;
  *model = build();
  save(*model, path);
  return status;
}

}  // namespace tac3d
