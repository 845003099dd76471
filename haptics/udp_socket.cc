#include "haptics/udp_socket.h"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <utility>

#include "engine/errors.h"

namespace hapvox::haptics {

UdpAddress parse_udp_address(const std::string& spec) {
  const std::string usage = "expected udp:HOST:PORT (e.g. udp:127.0.0.1:47001 or udp:[::1]:47001)";
  if (spec.rfind("udp:", 0) != 0) throw InputError(spec, usage);
  const std::string rest = spec.substr(4);
  UdpAddress address;
  std::string port_text;
  if (!rest.empty() && rest.front() == '[') {  // [IPv6]:PORT
    const std::size_t close = rest.find(']');
    if (close == std::string::npos || close + 1 >= rest.size() || rest[close + 1] != ':') {
      throw InputError(spec, usage);
    }
    address.host = rest.substr(1, close - 1);
    port_text = rest.substr(close + 2);
  } else {
    const std::size_t colon = rest.rfind(':');
    if (colon == std::string::npos || rest.find(':') != colon) throw InputError(spec, usage);
    address.host = rest.substr(0, colon);
    port_text = rest.substr(colon + 1);
  }
  if (address.host.empty()) throw InputError(spec, "no host (" + usage + ")");
  unsigned port = 0;
  const auto [end, ec] =
      std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (port_text.empty() || ec != std::errc() || end != port_text.data() + port_text.size() ||
      port > 65535) {
    throw InputError(spec, "port '" + port_text + "' is not a number in 0..65535");
  }
  address.port = static_cast<std::uint16_t>(port);
  return address;
}

SocketAddress resolve_udp_address(const UdpAddress& address, const std::string& source) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_DGRAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(address.port);
  if (const int rc = getaddrinfo(address.host.c_str(), port.c_str(), &hints, &found); rc != 0) {
    throw InputError(source, "cannot resolve host '" + address.host + "': " + gai_strerror(rc));
  }
  SocketAddress resolved;
  std::memcpy(&resolved.storage, found->ai_addr, found->ai_addrlen);
  resolved.length = found->ai_addrlen;
  freeaddrinfo(found);
  return resolved;
}

namespace {

// The IPv4 address and port of `a`, when it is IPv4 or IPv4-mapped IPv6.
bool as_ipv4(const SocketAddress& a, in_addr* address, in_port_t* port) noexcept {
  if (a.storage.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a.storage);
    *address = v4->sin_addr;
    *port = v4->sin_port;
    return true;
  }
  if (a.storage.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a.storage);
    if (!IN6_IS_ADDR_V4MAPPED(&v6->sin6_addr)) return false;
    std::memcpy(&address->s_addr, v6->sin6_addr.s6_addr + 12, 4);
    *port = v6->sin6_port;
    return true;
  }
  return false;
}

}  // namespace

bool same_endpoint(const SocketAddress& a, const SocketAddress& b) noexcept {
  in_addr a4{}, b4{};
  in_port_t a_port = 0, b_port = 0;
  const bool a_is_v4 = as_ipv4(a, &a4, &a_port), b_is_v4 = as_ipv4(b, &b4, &b_port);
  if (a_is_v4 || b_is_v4) {
    return a_is_v4 && b_is_v4 && a4.s_addr == b4.s_addr && a_port == b_port;
  }
  if (a.storage.ss_family != AF_INET6 || b.storage.ss_family != AF_INET6) return false;
  const auto* a6 = reinterpret_cast<const sockaddr_in6*>(&a.storage);
  const auto* b6 = reinterpret_cast<const sockaddr_in6*>(&b.storage);
  return std::memcmp(&a6->sin6_addr, &b6->sin6_addr, sizeof a6->sin6_addr) == 0 &&
         a6->sin6_port == b6->sin6_port && a6->sin6_scope_id == b6->sin6_scope_id;
}

std::string endpoint_text(const SocketAddress& address) {
  char host[NI_MAXHOST], port[NI_MAXSERV];
  if (getnameinfo(reinterpret_cast<const sockaddr*>(&address.storage), address.length, host,
                  sizeof host, port, sizeof port, NI_NUMERICHOST | NI_NUMERICSERV) != 0) {
    return "?";
  }
  if (address.storage.ss_family == AF_INET6) return "[" + std::string(host) + "]:" + port;
  return std::string(host) + ":" + port;
}

UdpSocket UdpSocket::bound(const UdpAddress& local, const std::string& source) {
  const SocketAddress at = resolve_udp_address(local, source);
  const std::string where = local.host + ":" + std::to_string(local.port);
  const int fd = ::socket(at.storage.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    throw InputError(source, "cannot listen on " + where + ": " + std::strerror(errno));
  }
  UdpSocket socket(fd);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&at.storage), at.length) != 0) {
    throw InputError(source, "cannot listen on " + where + ": " + std::strerror(errno));
  }
  return socket;
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}

UdpSocket& UdpSocket::operator=(UdpSocket&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) ::close(fd_);
}

std::uint16_t UdpSocket::local_port() const {
  sockaddr_storage at{};
  socklen_t length = sizeof at;
  if (::getsockname(fd_, reinterpret_cast<sockaddr*>(&at), &length) != 0) return 0;
  if (at.ss_family == AF_INET) {
    return ntohs(reinterpret_cast<const sockaddr_in*>(&at)->sin_port);
  }
  return ntohs(reinterpret_cast<const sockaddr_in6*>(&at)->sin6_port);
}

long UdpSocket::receive(std::uint8_t* buffer, std::size_t capacity, SocketAddress* from) noexcept {
  SocketAddress sender;
  sender.length = sizeof sender.storage;
  // MSG_TRUNC: the real length of a datagram longer than the buffer (it is oversized).
  const ssize_t n = ::recvfrom(fd_, buffer, capacity, MSG_TRUNC | MSG_DONTWAIT,
                               reinterpret_cast<sockaddr*>(&sender.storage), &sender.length);
  if (n < 0) return -1;
  if (from != nullptr) *from = sender;
  return static_cast<long>(n);
}

bool UdpSocket::wait_readable(std::chrono::nanoseconds timeout) const noexcept {
  pollfd p{fd_, POLLIN, 0};
  const std::int64_t ns = std::max<std::int64_t>(0, timeout.count());
  const timespec wait{static_cast<time_t>(ns / 1000000000), static_cast<long>(ns % 1000000000)};
  return ::ppoll(&p, 1, &wait, nullptr) > 0 && (p.revents & POLLIN) != 0;
}

bool UdpSocket::send_to(const std::uint8_t* data, std::size_t size,
                        const SocketAddress& to) noexcept {
  const ssize_t n = ::sendto(fd_, data, size, MSG_DONTWAIT,
                             reinterpret_cast<const sockaddr*>(&to.storage), to.length);
  return n == static_cast<ssize_t>(size);
}

}  // namespace hapvox::haptics
