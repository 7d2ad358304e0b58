#pragma once

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "tac3d/protocol/frame_assembler.h"

namespace tac3d {

namespace internal {

/// A bound IPv4 UDP socket (RAII, move-only). Errors throw tac3d::Error with the call and
/// strerror.
class UdpSocket {
 public:
  /// Binds to `local` (port 0: an ephemeral port). @param receive_buffer_bytes 0 keeps the
  /// system default; the kernel caps larger requests at net.core.rmem_max.
  explicit UdpSocket(const Endpoint& local, int receive_buffer_bytes = 0);
  ~UdpSocket();
  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&&) = delete;
  UdpSocket(const UdpSocket&) = delete;

  Endpoint local_endpoint() const;
  /// Sends one datagram made of `parts` joined, without copying them.
  void SendTo(const Endpoint& to, std::initializer_list<std::string_view> parts);
  /// Receives one datagram into `buffer`, waiting up to `wait_s` (0: only what is queued).
  /// @return its size (datagrams longer than the buffer are truncated), or nullopt if none came.
  std::optional<std::size_t> Receive(std::span<std::uint8_t> buffer, double wait_s, Endpoint* from);

 private:
  int fd_ = -1;
};

}  // namespace internal
}  // namespace tac3d
