#pragma once

// Test-only (not installed): a receiver that behaves as the vendor's C++ client (libTac3D, SDK
// 3.2.1) does, written from the facts in docs/pipeline.md ("The UDP stream and the vendor's
// clients"), not from the vendor's code. It shares nothing with tac3d's own decoder
// (FrameAssembler, DecodeFrame), so a fault there cannot hide one in the sender.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "tac3d/util/error.h"

namespace tac3d::testing {

/// The vendor C++ client's behaviour: it registers the five matrices and InitializeProgress
/// (a double) before any frame; for each item of a frame's header it looks the name up among
/// them and copies the item's bytes into the registered storage by the type the header names
/// (an `i32` copies 4 bytes into the 8-byte double, which then never equals 100); an item not
/// registered is a complaint (the client prints `frame field not found : NAME (get).`); the
/// user's callback runs only when the double equals 100.0.
class VendorCppClient {
 public:
  /// Binds 127.0.0.1:port (0: an ephemeral port).
  explicit VendorCppClient(std::uint16_t port = 0) : socket_(::socket(AF_INET, SOCK_DGRAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const int buffer_bytes = 4 << 20;
    ::setsockopt(socket_, SOL_SOCKET, SO_RCVBUF, &buffer_bytes, sizeof(buffer_bytes));
    if (socket_ < 0 ||
        ::bind(socket_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
      throw Error("VendorCppClient: cannot bind a UDP socket");
    }
    for (const char* name : {"3D_Positions",
                             "3D_Displacements",
                             "3D_Forces",
                             "3D_ResultantForce",
                             "3D_ResultantMoment"}) {
      matrices_[name];
    }
  }
  ~VendorCppClient() { ::close(socket_); }
  VendorCppClient(const VendorCppClient&) = delete;
  VendorCppClient& operator=(const VendorCppClient&) = delete;

  std::uint16_t port() const {
    sockaddr_in address{};
    socklen_t size = sizeof(address);
    ::getsockname(socket_, reinterpret_cast<sockaddr*>(&address), &size);
    return ntohs(address.sin_port);
  }

  /// Takes datagrams until none arrives for `idle_s` seconds or `max_s` have passed.
  void ReceiveUntilIdle(double idle_s, double max_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(max_s);
    std::vector<std::uint8_t> buffer(1 << 16);
    while (std::chrono::steady_clock::now() < end) {
      pollfd fd{socket_, POLLIN, 0};
      if (::poll(&fd, 1, static_cast<int>(idle_s * 1000)) <= 0) return;
      const ssize_t size = ::recv(socket_, buffer.data(), buffer.size(), 0);
      if (size >= 8) Take(buffer.data(), static_cast<std::size_t>(size));
    }
  }

  /// The indices of the frames the callback was called with, in order.
  const std::vector<std::int64_t>& delivered() const { return delivered_; }
  /// Complaints about unknown items, over every frame.
  int complaints() const { return complaints_; }
  /// The names complained about.
  const std::set<std::string>& unknown_items() const { return unknown_items_; }
  /// Frames completed (delivered or not).
  int frames_completed() const { return frames_completed_; }
  /// Bytes of each registered matrix as the last frame wrote them.
  std::size_t matrix_bytes(const std::string& name) const { return matrices_.at(name).size(); }

 private:
  struct Partial {
    std::string header;
    std::vector<char> body;
    int received = 0;
  };

  void Take(const std::uint8_t* datagram, std::size_t size) {
    std::uint32_t frame_id;
    std::uint16_t count, index;
    std::memcpy(&frame_id, datagram, 4);
    std::memcpy(&count, datagram + 4, 2);
    std::memcpy(&index, datagram + 6, 2);
    Partial& partial = partials_[frame_id];
    const char* payload = reinterpret_cast<const char*>(datagram) + 8;
    if (index == 0) {
      partial.header.assign(payload, size - 8);
    } else {
      // Chunk k at (k - 1) * 1392, as the vendor client writes it.
      const std::size_t offset = (index - 1) * std::size_t{1392};
      if (partial.body.size() < offset + size - 8) partial.body.resize(offset + size - 8);
      std::memcpy(partial.body.data() + offset, payload, size - 8);
    }
    if (++partial.received < count + 1) return;
    Complete(partial);
    partials_.erase(frame_id);
  }

  void Complete(const Partial& partial) {
    ++frames_completed_;
    const YAML::Node header = YAML::Load(partial.header);
    for (const YAML::Node& item : header["data"]) {
      const auto name = item["name"].as<std::string>();
      const auto type = item["type"].as<std::string>();
      const auto offset = item["offset"].as<std::size_t>();
      const auto length = item["length"].as<std::size_t>();
      const char* bytes = partial.body.data() + offset;
      if (name == "InitializeProgress") {
        // By the header's type: f64 fills the double, i32 only its first 4 bytes.
        std::memcpy(&progress_, bytes, type == "i32" ? 4 : 8);
      } else if (const auto it = matrices_.find(name); it != matrices_.end()) {
        it->second.assign(bytes, bytes + length);
      } else {
        ++complaints_;
        unknown_items_.insert(name);
      }
    }
    if (progress_ == 100.0) delivered_.push_back(header["index"].as<std::int64_t>());
  }

  int socket_;
  std::map<std::uint32_t, Partial> partials_;
  std::map<std::string, std::vector<char>> matrices_;
  double progress_ = 0.0;
  std::vector<std::int64_t> delivered_;
  int complaints_ = 0;
  std::set<std::string> unknown_items_;
  int frames_completed_ = 0;
};

}  // namespace tac3d::testing
