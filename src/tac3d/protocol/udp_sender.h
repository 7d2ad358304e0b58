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

/// What a sender streams (docs/pipeline.md, "The UDP stream and the vendor's clients"). The
/// defaults are what every vendor client takes: the vendor's six items and no frame before the
/// reference is taken.
struct StreamOptions {
  /// tac3d's extra items sent after the vendor's six, as ParseExtraItems reads them
  /// ("3D_Normals,SlipState", "all"); "" (the default): the six only.
  std::string items = "";
  /// Also send the frames taken while the reference is taken, at the start and after a `$C`
  /// (initialize_progress < 100). false (the default): none of them, since the vendor's
  /// PyTac3D 3.3.0-p1 stops receiving for good at the first.
  bool send_initializing = false;

  /// @throws Error naming an item that is not an extra one, as ParseExtraItems.
  void Validate() const;
};

struct UdpSenderOptions {
  std::string host = "127.0.0.1";  ///< where the client listens
  std::uint16_t port = 9988;       ///< the client's port
  std::uint16_t local_port = 0;    ///< the sending (and command) socket's port; 0: ephemeral
  StreamOptions stream = {};       ///< what each frame carries, and which frames are sent

  /// @throws Error naming the field: host not empty, port != 0, stream as StreamOptions.
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

  /// Encodes (EncodeFrame, with the options' extra items) and sends one frame, with `image`
  /// as PNG when it is not empty; a frame still initialising (initialize_progress < 100) is
  /// withheld instead unless StreamOptions::send_initializing.
  /// @throws Error as EncodeFrame does, or when the system refuses a datagram.
  void Send(const TactileFrame& frame, const cv::Mat& image = cv::Mat());

  /// The next command waiting on the sending socket, without blocking; nullopt when none.
  /// Datagrams that are not exactly "$C" or "$Q", or that do not come from the destination's
  /// address, are discarded and counted in ignored_datagrams().
  std::optional<SensorCommand> PollCommand();

  Endpoint local_endpoint() const;
  const Endpoint& destination() const { return destination_; }
  std::int64_t ignored_datagrams() const { return ignored_datagrams_; }
  /// Frames sent, and frames withheld while initialising, so far.
  std::int64_t frames_sent() const { return frames_sent_; }
  std::int64_t frames_withheld() const { return frames_withheld_; }

 private:
  std::unique_ptr<internal::UdpSocket> socket_;  // behind a pointer: its header is internal
  Endpoint destination_;
  ExtraItems extras_;
  bool send_initializing_;
  std::int64_t frames_sent_ = 0;
  std::int64_t frames_withheld_ = 0;
  std::uint32_t next_frame_id_;
  EncodedFrame encoded_;
  std::int64_t ignored_datagrams_ = 0;
};

}  // namespace tac3d
