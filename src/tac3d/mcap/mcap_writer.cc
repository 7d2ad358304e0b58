#include "tac3d/mcap/mcap_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

#include "tac3d/record/recording.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Little-endian appenders for the record fields (the spec's types).
template <typename T>
void Put(std::vector<std::uint8_t>& b, T value) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
  b.insert(b.end(), p, p + sizeof(T));
}
void PutString(std::vector<std::uint8_t>& b, const std::string& s) {
  Put(b, static_cast<std::uint32_t>(s.size()));
  b.insert(b.end(), s.begin(), s.end());
}
// A record: opcode, u64 content length, content.
void PutRecord(std::vector<std::uint8_t>& b, McapOp op, const std::vector<std::uint8_t>& content) {
  Put(b, static_cast<std::uint8_t>(op));
  Put(b, static_cast<std::uint64_t>(content.size()));
  b.insert(b.end(), content.begin(), content.end());
}

}  // namespace

McapWriter::McapWriter(const std::string& path, const std::string& profile, std::size_t chunk_bytes)
    : path_(path), out_(path, std::ios::binary | std::ios::trunc), chunk_bytes_(chunk_bytes) {
  if (!out_) throw Error(fmt::format("cannot create MCAP file '{}'", path));
  std::vector<std::uint8_t> b(std::begin(kMcapMagic), std::end(kMcapMagic));
  std::vector<std::uint8_t> header;
  PutString(header, profile);
  PutString(header, "tac3d");
  PutRecord(b, McapOp::kHeader, header);
  WriteRaw(b);
}

std::uint16_t McapWriter::AddSchema(const std::string& name, const std::string& encoding, const std::string& data) {
  const std::uint16_t id = ++schema_count_;  // 0 means "no schema"
  std::vector<std::uint8_t> content;
  Put(content, id);
  PutString(content, name);
  PutString(content, encoding);
  PutString(content, data);  // bytes: the same u32 length prefix
  PutRecord(schemas_, McapOp::kSchema, content);
  PutRecord(chunk_, McapOp::kSchema, content);  // before the messages that need it, for stream readers
  return id;
}

std::uint16_t McapWriter::AddChannel(std::uint16_t schema_id, const std::string& topic,
                                     const std::string& message_encoding) {
  const std::uint16_t id = channel_count_++;
  std::vector<std::uint8_t> content;
  Put(content, id);
  Put(content, schema_id);
  PutString(content, topic);
  PutString(content, message_encoding);
  Put(content, std::uint32_t{0});  // metadata: an empty map
  PutRecord(channels_, McapOp::kChannel, content);
  PutRecord(chunk_, McapOp::kChannel, content);
  return id;
}

void McapWriter::Write(std::uint16_t channel_id, std::uint64_t time_ns, const std::vector<std::uint8_t>& data) {
  chunk_index_[channel_id].emplace_back(time_ns, chunk_.size());
  Put(chunk_, static_cast<std::uint8_t>(McapOp::kMessage));
  Put(chunk_, static_cast<std::uint64_t>(2 + 4 + 8 + 8 + data.size()));
  Put(chunk_, channel_id);
  Put(chunk_, channel_sequence_[channel_id]++);
  Put(chunk_, time_ns);  // log time
  Put(chunk_, time_ns);  // publish time
  chunk_.insert(chunk_.end(), data.begin(), data.end());
  chunk_start_ns_ = chunk_has_messages_ ? std::min(chunk_start_ns_, time_ns) : time_ns;
  chunk_end_ns_ = chunk_has_messages_ ? std::max(chunk_end_ns_, time_ns) : time_ns;
  start_ns_ = message_count_ > 0 ? std::min(start_ns_, time_ns) : time_ns;
  end_ns_ = message_count_ > 0 ? std::max(end_ns_, time_ns) : time_ns;
  chunk_has_messages_ = true;
  ++message_count_;
  ++channel_messages_[channel_id];
  if (chunk_.size() >= chunk_bytes_) FlushChunk();
}

void McapWriter::WriteRaw(const std::vector<std::uint8_t>& bytes) {
  out_.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out_) throw Error(fmt::format("cannot write MCAP file '{}'", path_));
  offset_ += bytes.size();
}

void McapWriter::FlushChunk() {
  if (chunk_.empty()) return;
  std::vector<std::uint8_t> b;
  Put(b, static_cast<std::uint8_t>(McapOp::kChunk));
  Put(b, static_cast<std::uint64_t>(8 + 8 + 8 + 4 + 4 + 8 + chunk_.size()));
  Put(b, chunk_start_ns_);
  Put(b, chunk_end_ns_);
  Put(b, static_cast<std::uint64_t>(chunk_.size()));  // uncompressed size
  Put(b, Crc32(0, chunk_.data(), chunk_.size()));
  PutString(b, "");                                   // no compression
  Put(b, static_cast<std::uint64_t>(chunk_.size()));  // records, u64 length prefix
  ChunkIndex index{chunk_start_ns_, chunk_end_ns_, offset_, b.size() + chunk_.size(), 0, chunk_.size(), {}};
  WriteRaw(b);
  WriteRaw(chunk_);
  const std::uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    std::vector<std::uint8_t> content;
    Put(content, channel);
    Put(content, static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [time_ns, offset] : entries) {
      Put(content, time_ns);
      Put(content, offset);
    }
    std::vector<std::uint8_t> record;
    PutRecord(record, McapOp::kMessageIndex, content);
    index.message_index_offsets.emplace_back(channel, offset_);
    WriteRaw(record);
  }
  index.message_index_length = offset_ - indexes_start;
  chunk_indexes_.push_back(std::move(index));
  chunk_.clear();
  chunk_index_.clear();
  chunk_has_messages_ = false;
}

void McapWriter::Close() {
  FlushChunk();
  std::vector<std::uint8_t> data_end;
  Put(data_end, std::uint32_t{0});  // no data section CRC: each chunk carries its own
  std::vector<std::uint8_t> b;
  PutRecord(b, McapOp::kDataEnd, data_end);
  WriteRaw(b);

  // The summary, one group per record type; each group's place goes in a summary offset.
  const std::uint64_t summary_start = offset_;
  std::vector<std::uint8_t> summary;
  std::vector<std::uint8_t> offsets;
  const auto group = [&](McapOp op, const std::vector<std::uint8_t>& records) {
    if (records.empty()) return;
    std::vector<std::uint8_t> content;
    Put(content, static_cast<std::uint8_t>(op));
    Put(content, summary_start + summary.size());
    Put(content, static_cast<std::uint64_t>(records.size()));
    PutRecord(offsets, McapOp::kSummaryOffset, content);
    summary.insert(summary.end(), records.begin(), records.end());
  };
  group(McapOp::kSchema, schemas_);
  group(McapOp::kChannel, channels_);
  std::vector<std::uint8_t> statistics;
  {
    std::vector<std::uint8_t> content;
    Put(content, message_count_);
    Put(content, schema_count_);
    Put(content, static_cast<std::uint32_t>(channel_count_));
    Put(content, std::uint32_t{0});  // attachments
    Put(content, std::uint32_t{0});  // metadata
    Put(content, static_cast<std::uint32_t>(chunk_indexes_.size()));
    Put(content, start_ns_);
    Put(content, end_ns_);
    Put(content, static_cast<std::uint32_t>(channel_messages_.size() * 10));
    for (const auto& [channel, count] : channel_messages_) {
      Put(content, channel);
      Put(content, count);
    }
    PutRecord(statistics, McapOp::kStatistics, content);
  }
  group(McapOp::kStatistics, statistics);
  std::vector<std::uint8_t> chunk_indexes;
  for (const ChunkIndex& c : chunk_indexes_) {
    std::vector<std::uint8_t> content;
    Put(content, c.start_ns);
    Put(content, c.end_ns);
    Put(content, c.offset);
    Put(content, c.length);
    Put(content, static_cast<std::uint32_t>(c.message_index_offsets.size() * 10));
    for (const auto& [channel, offset] : c.message_index_offsets) {
      Put(content, channel);
      Put(content, offset);
    }
    Put(content, c.message_index_length);
    PutString(content, "");
    Put(content, c.records_size);  // compressed size: stored uncompressed
    Put(content, c.records_size);
    PutRecord(chunk_indexes, McapOp::kChunkIndex, content);
  }
  group(McapOp::kChunkIndex, chunk_indexes);

  const std::uint64_t offsets_start = summary_start + summary.size();
  summary.insert(summary.end(), offsets.begin(), offsets.end());
  std::vector<std::uint8_t> footer_start;
  Put(footer_start, static_cast<std::uint8_t>(McapOp::kFooter));
  Put(footer_start, std::uint64_t{8 + 8 + 4});
  Put(footer_start, summary_start);
  Put(footer_start, offsets_start);
  // The summary's CRC runs from its start through the footer's summary_offset_start.
  std::uint32_t summary_crc = Crc32(0, summary.data(), summary.size());
  summary_crc = Crc32(summary_crc, footer_start.data(), footer_start.size());
  Put(footer_start, summary_crc);
  footer_start.insert(footer_start.end(), std::begin(kMcapMagic), std::end(kMcapMagic));
  WriteRaw(summary);
  WriteRaw(footer_start);
  out_.close();
  if (!out_) throw Error(fmt::format("cannot write MCAP file '{}'", path_));
}

}  // namespace tac3d
