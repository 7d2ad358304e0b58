#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tac3d/protocol/wire_format.h"

namespace tac3d {

/// An IPv4 UDP endpoint, address and port in host byte order.
struct Endpoint {
  std::uint32_t address = 0;
  std::uint16_t port = 0;

  std::string ToString() const;  ///< "127.0.0.1:9988"
  bool operator==(const Endpoint&) const = default;
};

/// Resolves an IPv4 host (dotted quad or a name) and a port.
/// @throws Error naming the host when it does not resolve to an IPv4 address.
Endpoint ResolveEndpoint(const std::string& host, std::uint16_t port);

namespace internal {
class UdpSocket;  // udp_socket.h, not installed
}  // namespace internal

struct FrameAssemblerOptions {
  double timeout_s = 1.0;    ///< an incomplete frame older than this is dropped
  int max_in_progress = 30;  ///< more incomplete frames than this: the oldest is dropped
  /// Frames whose packet_count * 1392 exceeds this are refused at their first datagram, so
  /// a hostile packet_count cannot make the client buffer without bound.
  std::size_t max_frame_bytes = 16u << 20;

  /// @throws Error naming the field: timeout_s > 0, max_in_progress >= 1,
  /// max_frame_bytes >= 1392.
  void Validate() const;
};

/// Number of datagrams or frames dropped, by reason (see DropReason for which counts what).
struct DropCounts {
  std::array<std::int64_t, kNumDropReasons> counts{};

  std::int64_t operator[](DropReason reason) const { return counts[static_cast<int>(reason)]; }
  std::int64_t total() const;
  std::string ToString() const;  ///< "timed_out=2 bad_header=1" (reasons with a count only)
};

/// A frame the assembler completed and decoded, with where it came from.
struct ReceivedFrame {
  DecodedFrame frame;
  Endpoint sender;
  double receive_time_s = 0.0;  ///< the `now_s` of the datagram that completed it
};

/// Reassembles Tac3D frames from datagrams, keyed by (sender, frame_id), in any order and
/// with duplicates; decodes each complete frame. No sockets, no clock: the caller passes the
/// time, so the Client and tests drive it alike. Malformed input is counted, never thrown.
class FrameAssembler {
 public:
  explicit FrameAssembler(const FrameAssemblerOptions& options = {});

  /// Takes one datagram received at `now_s` (any monotonic clock, seconds); returns the frame
  /// it completed, if it completed one that decodes. Drops frames that timed out first.
  std::optional<ReceivedFrame> Push(const Endpoint& sender,
                                    std::span<const std::uint8_t> datagram,
                                    double now_s);
  /// Drops the incomplete frames older than the timeout at `now_s`.
  void Expire(double now_s);

  int num_in_progress() const { return static_cast<int>(in_progress_.size()); }
  const DropCounts& drops() const { return drops_; }
  /// Why the last frame-level drop happened (the decoder's message), for logs.
  const std::string& last_error() const { return last_error_; }

 private:
  struct Partial {
    Endpoint sender;
    std::uint32_t frame_id = 0;
    std::uint16_t packet_count = 0;
    double first_seen_s = 0.0;
    int received = 0;
    std::vector<std::string> payloads;  // index 0: header; k: body chunk k
    std::vector<bool> have;
  };

  std::nullopt_t Drop(DropReason reason) {
    ++drops_.counts[static_cast<int>(reason)];
    return std::nullopt;
  }
  std::optional<ReceivedFrame> Complete(Partial& partial, double now_s);

  FrameAssemblerOptions options_;
  std::vector<Partial> in_progress_;  // at most max_in_progress: a linear search is cheapest
  DropCounts drops_;
  std::string last_error_;
  std::string body_;  // reused to join a frame's chunks
};

}  // namespace tac3d
