#include "tac3d/protocol/client.h"

#include <fmt/format.h>

#include "tac3d/protocol/udp_socket.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

// Larger than any UDP payload, so an oversized datagram arrives whole and is counted as such.
constexpr std::size_t kReceiveBufferBytes = 1 << 16;

// More datagrams than a 4 MiB socket buffer holds (4 MiB / 1400 B).
constexpr int kMaxLateDatagrams = 4096;

const ClientOptions& Validated(const ClientOptions& options) {
  options.Validate();
  return options;
}

}  // namespace

void ClientOptions::Validate() const {
  if (bind_address.empty()) throw Error("ClientOptions.bind_address must not be empty");
  if (receive_buffer_bytes < 0) {
    throw Error(
        fmt::format("ClientOptions.receive_buffer_bytes = {} must be >= 0", receive_buffer_bytes));
  }
  assembler.Validate();
}

Client::Client(const ClientOptions& options)
    : socket_(std::make_unique<internal::UdpSocket>(
          ResolveEndpoint(Validated(options).bind_address, options.port),
          options.receive_buffer_bytes)),
      assembler_(options.assembler),
      buffer_(kReceiveBufferBytes) {}

Client::Client(Client&&) noexcept = default;
Client::~Client() = default;

Endpoint Client::local_endpoint() const { return socket_->local_endpoint(); }

double Client::Now() const {
  return SecondsSince(start_);
}

std::optional<ReceivedFrame> Client::Receive(double wait_s) {
  const double deadline = Now() + wait_s;
  int late_datagrams = 0;
  for (;;) {
    Endpoint from;
    const auto size = socket_->Receive(buffer_, deadline - Now(), &from);
    const double now = Now();
    if (!size) {
      if (now < deadline) continue;  // interrupted: wait out the rest
      assembler_.Expire(now);
      return std::nullopt;
    }
    if (auto frame = assembler_.Push(from, std::span(buffer_.data(), *size), now)) return frame;
    // Past the deadline keep draining what is queued, but no more than a full kernel buffer,
    // so a flood of garbage cannot hold the caller.
    if (now >= deadline && ++late_datagrams >= kMaxLateDatagrams) return std::nullopt;
  }
}

void Client::SendCommand(const Endpoint& sensor, SensorCommand command) {
  socket_->SendTo(sensor, {CommandBytes(command)});
}

}  // namespace tac3d
