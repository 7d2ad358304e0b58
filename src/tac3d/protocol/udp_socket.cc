#include "tac3d/protocol/udp_socket.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <vector>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

sockaddr_in ToSockaddr(const Endpoint& endpoint) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(endpoint.address);
  addr.sin_port = htons(endpoint.port);
  return addr;
}

Endpoint FromSockaddr(const sockaddr_in& addr) {
  return {ntohl(addr.sin_addr.s_addr), ntohs(addr.sin_port)};
}

[[noreturn]] void ThrowErrno(const std::string& what) {
  throw Error(fmt::format("{}: {}", what, std::strerror(errno)));
}

}  // namespace

Endpoint ResolveEndpoint(const std::string& host, std::uint16_t port) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* result = nullptr;
  if (const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &result); rc != 0) {
    throw Error(
        fmt::format("cannot resolve host '{}' to an IPv4 address: {}", host, gai_strerror(rc)));
  }
  Endpoint endpoint = FromSockaddr(*reinterpret_cast<const sockaddr_in*>(result->ai_addr));
  freeaddrinfo(result);
  endpoint.port = port;
  return endpoint;
}

namespace internal {

UdpSocket::UdpSocket(const Endpoint& local, int receive_buffer_bytes) {
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) ThrowErrno("socket(AF_INET, SOCK_DGRAM)");
  if (receive_buffer_bytes > 0) {
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof(receive_buffer_bytes));
  }
  const sockaddr_in addr = ToSockaddr(local);
  if (bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int saved = errno;
    close(fd_);
    errno = saved;
    ThrowErrno(fmt::format("cannot bind UDP {}", local.ToString()));
  }
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) close(fd_);
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

Endpoint UdpSocket::local_endpoint() const {
  sockaddr_in addr{};
  socklen_t size = sizeof(addr);
  if (getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &size) != 0) ThrowErrno("getsockname");
  return FromSockaddr(addr);
}

void UdpSocket::SendTo(const Endpoint& to, std::initializer_list<std::string_view> parts) {
  iovec iov[4];
  TAC3D_DEMAND(parts.size() <= std::size(iov));
  int n = 0;
  for (const std::string_view part : parts) {
    iov[n++] = {const_cast<char*>(part.data()), part.size()};
  }
  sockaddr_in addr = ToSockaddr(to);
  msghdr message{};
  message.msg_name = &addr;
  message.msg_namelen = sizeof(addr);
  message.msg_iov = iov;
  message.msg_iovlen = n;
  while (sendmsg(fd_, &message, 0) < 0) {
    if (errno != EINTR) ThrowErrno(fmt::format("cannot send a datagram to {}", to.ToString()));
  }
}

std::optional<std::size_t> UdpSocket::Receive(std::span<std::uint8_t> buffer,
                                              double wait_s,
                                              Endpoint* from) {
  pollfd pfd{fd_, POLLIN, 0};
  const int wait_ms = static_cast<int>(std::ceil(std::max(wait_s, 0.0) * 1e3));
  const int ready = poll(&pfd, 1, wait_ms);
  if (ready < 0 && errno != EINTR) ThrowErrno("poll on a UDP socket");
  if (ready <= 0) return std::nullopt;
  sockaddr_in addr{};
  socklen_t size = sizeof(addr);
  const ssize_t n = recvfrom(
      fd_, buffer.data(), buffer.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&addr), &size);
  if (n < 0) {
    // An ICMP error queued by an earlier send, or a race with another reader: not fatal.
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR || errno == ECONNREFUSED) {
      return std::nullopt;
    }
    ThrowErrno("recvfrom on a UDP socket");
  }
  *from = FromSockaddr(addr);
  return static_cast<std::size_t>(n);
}

}  // namespace internal
}  // namespace tac3d
