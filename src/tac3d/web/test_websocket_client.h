// A small blocking WebSocket client (RFC 6455) on a plain socket, for the viewer server's tests
// and benchmark: written apart from the Boost.Beast code it talks to, and without Boost, whose
// headers took a Beast client's translation unit 15-20 s to compile.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

namespace tac3d::testing {

class WebSocketClient {
 public:
  // Connects to 127.0.0.1:port and completes the handshake on /ws; throws if refused. A Read
  // gives up after timeout_s without data (0: waits for ever).
  explicit WebSocketClient(std::uint16_t port, double timeout_s = 5.0) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd_ < 0) throw std::runtime_error("websocket client: no socket");
    if (timeout_s > 0) {
      timeval tv{};
      tv.tv_sec = static_cast<time_t>(timeout_s);
      tv.tv_usec = static_cast<suseconds_t>((timeout_s - static_cast<double>(tv.tv_sec)) * 1e6);
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(fd_);
      throw std::runtime_error("websocket client: connection refused");
    }
    // The key and its accept value are RFC 6455's own example (section 1.3).
    SendAll("GET /ws HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
            "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n");
    std::string response;
    while (response.size() < 4 || response.compare(response.size() - 4, 4, "\r\n\r\n") != 0) {
      if (response.size() > 8192) throw std::runtime_error("websocket client: endless handshake response");
      response += ReadExactly(1);  // byte by byte: nothing after the header is consumed
    }
    if (response.rfind("HTTP/1.1 101 ", 0) != 0 ||
        response.find("Sec-WebSocket-Accept: s3pPLMBiTxaQ9kYGzzhZRbK+xOo=\r\n") == std::string::npos) {
      ::close(fd_);
      throw std::runtime_error("websocket client: handshake refused: " + response.substr(0, response.find('\r')));
    }
  }
  ~WebSocketClient() { ::close(fd_); }
  WebSocketClient(const WebSocketClient&) = delete;
  WebSocketClient& operator=(const WebSocketClient&) = delete;

  // The next text or binary message, its fragments joined; pings are answered. Throws when the
  // connection ends, the server closes it, or nothing arrives within the timeout.
  std::string Read() {
    std::string message;
    for (;;) {
      const std::string head = ReadExactly(2);
      const bool final_fragment = head[0] & 0x80;
      const int opcode = head[0] & 0x0f;
      std::uint64_t size = head[1] & 0x7f;
      if (size >= 126) {
        const std::string extended = ReadExactly(size == 126 ? 2 : 8);
        size = 0;
        for (char c : extended) size = size << 8 | static_cast<unsigned char>(c);
      }
      if (size > kMaxMessageBytes) throw std::runtime_error("websocket client: frame too large");
      const std::string mask = (head[1] & 0x80) ? ReadExactly(4) : std::string();
      std::string payload = ReadExactly(static_cast<size_t>(size));
      for (size_t i = 0; i < payload.size() && !mask.empty(); ++i) payload[i] ^= mask[i % 4];
      if (opcode == kClose) throw std::runtime_error("websocket client: closed by the server");
      if (opcode == kPing) {
        SendFrame(kPong, payload);
        continue;
      }
      if (opcode == kPong) continue;
      message += payload;
      if (message.size() > kMaxMessageBytes) throw std::runtime_error("websocket client: message too large");
      if (final_fragment) return message;
    }
  }

  // One text message.
  void Write(const std::string& text) { SendFrame(kText, text); }

  // A normal close (1000), then the server's close frame or the end of the connection.
  void Close() {
    SendFrame(kClose, std::string("\x03\xe8", 2));
    try {
      for (;;) Read();
    } catch (const std::runtime_error&) {
    }
  }

  // Gone without a close frame; also ends a Read blocked on another thread.
  void Disconnect() { ::shutdown(fd_, SHUT_RDWR); }

 private:
  static constexpr int kText = 0x1, kClose = 0x8, kPing = 0x9, kPong = 0xa;
  static constexpr std::uint64_t kMaxMessageBytes = 64u << 20;

  void SendAll(const std::string& bytes) {
    for (size_t sent = 0; sent < bytes.size();) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error("websocket client: send failed");
      sent += static_cast<size_t>(n);
    }
  }

  std::string ReadExactly(size_t size) {
    std::string bytes(size, '\0');
    for (size_t got = 0; got < size;) {
      const ssize_t n = ::recv(fd_, bytes.data() + got, size - got, 0);
      if (n <= 0) throw std::runtime_error(n == 0 ? "websocket client: connection closed" : "websocket client: read failed or timed out");
      got += static_cast<size_t>(n);
    }
    return bytes;
  }

  // A client's frames are masked (RFC 6455, 5.3).
  void SendFrame(int opcode, const std::string& payload) {
    std::string frame(1, static_cast<char>(0x80 | opcode));
    const std::uint64_t size = payload.size();
    if (size < 126) {
      frame += static_cast<char>(0x80 | size);
    } else if (size < 65536) {
      frame += static_cast<char>(0x80 | 126);
      for (int shift = 8; shift >= 0; shift -= 8) frame += static_cast<char>(size >> shift);
    } else {
      frame += static_cast<char>(0x80 | 127);
      for (int shift = 56; shift >= 0; shift -= 8) frame += static_cast<char>(size >> shift);
    }
    const std::uint32_t key = mask_rng_();
    const char mask[4] = {static_cast<char>(key >> 24), static_cast<char>(key >> 16), static_cast<char>(key >> 8),
                          static_cast<char>(key)};
    frame.append(mask, 4);
    for (size_t i = 0; i < payload.size(); ++i) frame += static_cast<char>(payload[i] ^ mask[i % 4]);
    SendAll(frame);
  }

  int fd_ = -1;
  std::mt19937 mask_rng_{std::random_device{}()};
};

}  // namespace tac3d::testing
