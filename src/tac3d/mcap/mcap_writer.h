#pragma once

#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace tac3d {

// An MCAP writer (https://mcap.dev/spec, major version 0): the header, then uncompressed chunks
// of messages each followed by its message index records, the data end, a summary section
// (schemas, channels, statistics, chunk indexes) with its summary offsets, the footer. Messages
// stream to the file a chunk at a time; only the summary's indexes stay in memory.

/// The 8 magic bytes at both ends of an MCAP file.
inline constexpr std::uint8_t kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

/// Record opcodes.
enum class McapOp : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

class McapWriter {
 public:
  /// Creates (truncates) `path` and writes the magic and header record.
  /// @param profile the header's profile ("ros2").
  /// @param chunk_bytes a chunk is closed once its records exceed this.
  /// @throws Error if the file cannot be created.
  McapWriter(const std::string& path, const std::string& profile, std::size_t chunk_bytes = 1u << 20);

  /// @returns the new schema's id (1, 2, ...).
  std::uint16_t AddSchema(const std::string& name, const std::string& encoding, const std::string& data);
  /// @returns the new channel's id (0, 1, ...).
  std::uint16_t AddChannel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding);
  /// One message, log time and publish time `time_ns`.
  void Write(std::uint16_t channel_id, std::uint64_t time_ns, const std::vector<std::uint8_t>& data);

  /// Writes the last chunk, the data end, summary, summary offsets, footer and magic.
  /// @throws Error if a write failed.
  void Close();

  std::uint64_t messages() const { return message_count_; }

 private:
  struct ChunkIndex {
    std::uint64_t start_ns, end_ns, offset, length, message_index_length, records_size;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> message_index_offsets;
  };

  void WriteRaw(const std::vector<std::uint8_t>& bytes);
  void FlushChunk();

  std::string path_;
  std::ofstream out_;
  std::uint64_t offset_ = 0;
  std::size_t chunk_bytes_;
  std::vector<std::uint8_t> schemas_;   // the schema records, again in the summary
  std::vector<std::uint8_t> channels_;  // the channel records, again in the summary
  std::uint16_t schema_count_ = 0;
  std::uint16_t channel_count_ = 0;
  // The open chunk: its records, time range and each channel's (log time, offset) index.
  std::vector<std::uint8_t> chunk_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  bool chunk_has_messages_ = false;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::vector<ChunkIndex> chunk_indexes_;
  std::map<std::uint16_t, std::uint64_t> channel_messages_;
  std::map<std::uint16_t, std::uint32_t> channel_sequence_;
  std::uint64_t message_count_ = 0, start_ns_ = 0, end_ns_ = 0;
};

}  // namespace tac3d
