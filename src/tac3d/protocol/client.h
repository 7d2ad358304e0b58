#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/protocol/frame_assembler.h"
#include "tac3d/protocol/wire_format.h"

namespace tac3d {

struct ClientOptions {
  std::string bind_address = "0.0.0.0";  ///< all interfaces, as the vendor clients
  std::uint16_t port = 9988;             ///< 0: an ephemeral port (tests)
  FrameAssemblerOptions assembler{};
  /// SO_RCVBUF request, so bursts from several sensors are not dropped by the kernel.
  int receive_buffer_bytes = 4 << 20;

  /// @throws Error naming the field.
  void Validate() const;
};

/// A Tac3D client: binds a UDP port, reassembles and decodes the frames any number of
/// sensors send to it, and sends `$C` / `$Q` back. Malformed datagrams and frames are
/// dropped and counted (drops()), never thrown. Not thread-safe: one owner calls Receive.
class Client {
 public:
  /// @throws Error when the address does not resolve or the port cannot be bound.
  explicit Client(const ClientOptions& options);
  Client(Client&&) noexcept;
  ~Client();

  /// The next complete, decoded frame, waiting up to `wait_s` seconds for it; nullopt when
  /// none completed in that time and nothing more is queued. Receive(0) processes the
  /// datagrams already queued without waiting. Frames are returned whatever their
  /// InitializeProgress.
  std::optional<ReceivedFrame> Receive(double wait_s);

  /// Sends `$C` or `$Q` to a sensor (ReceivedFrame::sender) from the bound socket.
  void SendCommand(const Endpoint& sensor, SensorCommand command);

  Endpoint local_endpoint() const;
  const DropCounts& drops() const { return assembler_.drops(); }
  const std::string& last_error() const { return assembler_.last_error(); }

 private:
  double Now() const;

  std::unique_ptr<internal::UdpSocket> socket_;  // behind a pointer: its header is internal
  FrameAssembler assembler_;
  std::vector<std::uint8_t> buffer_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace tac3d
