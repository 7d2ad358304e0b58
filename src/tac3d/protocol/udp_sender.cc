#include "tac3d/protocol/udp_sender.h"

#include <fmt/format.h>

#include <array>
#include <random>

#include "tac3d/protocol/udp_socket.h"

namespace tac3d {

void StreamOptions::Validate() const { ParseExtraItems(items, "StreamOptions.items"); }

void UdpSenderOptions::Validate() const {
  if (host.empty()) throw Error("UdpSenderOptions.host must not be empty");
  if (port == 0) throw Error("UdpSenderOptions.port must not be 0");
  stream.Validate();
}

namespace {

const UdpSenderOptions& Validated(const UdpSenderOptions& options) {
  options.Validate();
  return options;
}

}  // namespace

UdpSender::UdpSender(const UdpSenderOptions& options)
    : socket_(std::make_unique<internal::UdpSocket>(Endpoint{0, Validated(options).local_port})),
      destination_(ResolveEndpoint(options.host, options.port)),
      extras_(ParseExtraItems(options.stream.items, "StreamOptions.items")),
      send_initializing_(options.stream.send_initializing),
      // A random first id: a restarted sender on the same port must not complete the
      // previous run's stale partial frames in the client.
      next_frame_id_(std::random_device{}()) {}

UdpSender::UdpSender(UdpSender&&) noexcept = default;
UdpSender::~UdpSender() = default;

Endpoint UdpSender::local_endpoint() const { return socket_->local_endpoint(); }

void UdpSender::Send(const TactileFrame& frame, const cv::Mat& image) {
  if (frame.initialize_progress < 100 && !send_initializing_) {
    ++frames_withheld_;
    return;
  }
  EncodeFrame(frame, next_frame_id_++, image, extras_, &encoded_);
  for (int k = 0; k <= encoded_.packet_count(); ++k) {
    const auto prefix = encoded_.Prefix(k).Bytes();
    socket_->SendTo(destination_,
                    {std::string_view(reinterpret_cast<const char*>(prefix.data()), prefix.size()),
                     encoded_.Payload(k)});
  }
  ++frames_sent_;
}

std::optional<SensorCommand> UdpSender::PollCommand() {
  // Larger than any command, so a longer datagram is seen as longer, not cut to "$C".
  std::array<std::uint8_t, 64> buffer;
  Endpoint from;
  while (const auto size = socket_->Receive(buffer, 0.0, &from)) {
    const auto command = ParseCommand(std::span(buffer.data(), *size));
    if (command && from.address == destination_.address) return command;
    ++ignored_datagrams_;
  }
  return std::nullopt;
}

}  // namespace tac3d
