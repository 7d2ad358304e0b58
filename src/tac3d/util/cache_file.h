#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

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

}  // namespace tac3d
