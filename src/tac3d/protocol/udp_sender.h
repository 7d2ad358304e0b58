#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/protocol/frame_assembler.h"
#include "tac3d/protocol/wire_format.h"

namespace tac3d {

struct UdpSenderOptions {
  std::string host = "127.0.0.1";  ///< where the client listens
  std::uint16_t port = 9988;       ///< the client's port
  std::uint16_t local_port = 0;    ///< the sending (and command) socket's port; 0: ephemeral

  /// @throws Error naming the field: host not empty, port != 0.
  void Validate() const;
};

/// Streams TactileFrames to one client as the Tac3D wire protocol, like the vendor's
/// processing program, and takes the `$C` / `$Q` commands the client sends back to the
/// sending socket. Each frame carries its own SN, so several senders (one per sensor) may
/// share a process and a client. Not thread-safe: one owner calls Send and PollCommand.
class UdpSender {
 public:
  /// @throws Error when the host does not resolve or the socket cannot be bound.
  explicit UdpSender(const UdpSenderOptions& options);
  UdpSender(UdpSender&&) noexcept;
  ~UdpSender();

  /// Encodes (EncodeFrame) and sends one frame, with `image` as PNG when it is not empty.
  /// @throws Error as EncodeFrame does, or when the system refuses a datagram.
  void Send(const TactileFrame& frame, const cv::Mat& image = cv::Mat());

  /// The next command waiting on the sending socket, without blocking; nullopt when none.
  /// Datagrams that are not exactly "$C" or "$Q", or that do not come from the destination's
  /// address, are discarded and counted in ignored_datagrams().
  std::optional<SensorCommand> PollCommand();

  Endpoint local_endpoint() const;
  const Endpoint& destination() const { return destination_; }
  std::int64_t ignored_datagrams() const { return ignored_datagrams_; }

 private:
  std::unique_ptr<internal::UdpSocket> socket_;  // behind a pointer: its header is internal
  Endpoint destination_;
  std::uint32_t next_frame_id_;
  EncodedFrame encoded_;
  std::int64_t ignored_datagrams_ = 0;
};

}  // namespace tac3d
