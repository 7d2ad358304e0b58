#include "tac3d/protocol/frame_assembler.h"

#include <fmt/format.h>

#include <algorithm>

namespace tac3d {

std::string Endpoint::ToString() const {
  return fmt::format("{}.{}.{}.{}:{}",
                     address >> 24,
                     (address >> 16) & 0xff,
                     (address >> 8) & 0xff,
                     address & 0xff,
                     port);
}

void FrameAssemblerOptions::Validate() const {
  if (!(timeout_s > 0.0)) {
    throw Error(fmt::format("FrameAssemblerOptions.timeout_s = {} must be > 0", timeout_s));
  }
  if (max_in_progress < 1) {
    throw Error(
        fmt::format("FrameAssemblerOptions.max_in_progress = {} must be >= 1", max_in_progress));
  }
  if (max_frame_bytes < kChunkBytes) {
    throw Error(fmt::format(
        "FrameAssemblerOptions.max_frame_bytes = {} must be >= {}", max_frame_bytes, kChunkBytes));
  }
}

std::int64_t DropCounts::total() const {
  std::int64_t sum = 0;
  for (const auto c : counts) sum += c;
  return sum;
}

std::string DropCounts::ToString() const {
  std::string text;
  for (int k = 0; k < kNumDropReasons; ++k) {
    if (counts[k] == 0) continue;
    if (!text.empty()) text += ' ';
    text += fmt::format("{}={}", DropReasonName(static_cast<DropReason>(k)), counts[k]);
  }
  return text;
}

FrameAssembler::FrameAssembler(const FrameAssemblerOptions& options) : options_(options) {
  options_.Validate();
}

void FrameAssembler::Expire(double now_s) {
  const auto old = std::remove_if(in_progress_.begin(), in_progress_.end(), [&](const Partial& p) {
    return now_s - p.first_seen_s > options_.timeout_s;
  });
  drops_.counts[static_cast<int>(DropReason::kTimedOut)] += in_progress_.end() - old;
  in_progress_.erase(old, in_progress_.end());
}

std::optional<ReceivedFrame> FrameAssembler::Push(const Endpoint& sender,
                                                  std::span<const std::uint8_t> datagram,
                                                  double now_s) {
  Expire(now_s);
  if (datagram.size() < kDatagramPrefixBytes) return Drop(DropReason::kShortDatagram);
  if (datagram.size() > kMaxDatagramBytes) {
    return Drop(DropReason::kOversizedDatagram);
  }
  const DatagramPrefix prefix = DatagramPrefix::Parse(datagram.data());
  if (prefix.packet_index > prefix.packet_count) {
    return Drop(DropReason::kBadPacketIndex);
  }
  if (std::size_t{prefix.packet_count} * kChunkBytes > options_.max_frame_bytes) {
    return Drop(DropReason::kFrameTooLarge);
  }
  const std::size_t payload_size = datagram.size() - kDatagramPrefixBytes;
  const bool inner_chunk = prefix.packet_index >= 1 && prefix.packet_index < prefix.packet_count;
  if (inner_chunk && payload_size != kChunkBytes) {
    return Drop(DropReason::kBadChunkSize);
  }

  auto it = std::find_if(in_progress_.begin(), in_progress_.end(), [&](const Partial& p) {
    return p.frame_id == prefix.frame_id && p.sender == sender;
  });
  if (it == in_progress_.end()) {
    if (static_cast<int>(in_progress_.size()) >= options_.max_in_progress) {
      // in_progress_ is in arrival order: the front is the oldest.
      in_progress_.erase(in_progress_.begin());
      Drop(DropReason::kEvicted);
    }
    Partial& partial = in_progress_.emplace_back();
    partial.sender = sender;
    partial.frame_id = prefix.frame_id;
    partial.packet_count = prefix.packet_count;
    partial.first_seen_s = now_s;
    partial.payloads.resize(prefix.packet_count + 1);
    partial.have.assign(prefix.packet_count + 1, false);
    it = in_progress_.end() - 1;
  }
  Partial& partial = *it;
  if (partial.packet_count != prefix.packet_count) {
    return Drop(DropReason::kInconsistentCount);
  }
  if (partial.have[prefix.packet_index]) return Drop(DropReason::kDuplicate);
  partial.have[prefix.packet_index] = true;
  partial.payloads[prefix.packet_index].assign(
      reinterpret_cast<const char*>(datagram.data()) + kDatagramPrefixBytes, payload_size);
  if (++partial.received < partial.packet_count + 1) return std::nullopt;

  Partial complete = std::move(partial);
  in_progress_.erase(it);
  return Complete(complete, now_s);
}

std::optional<ReceivedFrame> FrameAssembler::Complete(Partial& partial, double now_s) {
  body_.clear();
  for (int k = 1; k <= partial.packet_count; ++k) body_ += partial.payloads[k];
  try {
    return ReceivedFrame{DecodeFrame(partial.payloads[0], body_), partial.sender, now_s};
  } catch (const DecodeError& e) {
    Drop(e.reason());
    last_error_ =
        fmt::format("frame {} from {}: {}", partial.frame_id, partial.sender.ToString(), e.what());
    return std::nullopt;
  }
}

}  // namespace tac3d
