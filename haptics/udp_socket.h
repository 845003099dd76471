#pragma once
// The device bridge's transport: UDP over IPv4 or IPv6 (haptics/bridge_packet.h holds what
// the datagrams say). Receiving never blocks and never allocates, so the force thread can
// poll it once a tick; a datagram longer than the buffer reports its real length (the caller
// counts it as oversized). POSIX sockets: no library does this better for one socket.

#include <sys/socket.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

namespace hapvox::haptics {

/// "udp:HOST:PORT" (HOST a name, an IPv4 address or a bracketed IPv6 one: udp:[::1]:47001).
struct UdpAddress {
  std::string host;
  std::uint16_t port = 0;
};

/// Parses a --device / --to spec. Throws InputError(spec, ...) naming what is wrong.
UdpAddress parse_udp_address(const std::string& spec);

/// A socket address resolved from a UdpAddress.
struct SocketAddress {
  sockaddr_storage storage{};
  socklen_t length = 0;
};

/// Resolves `address` (numeric or by name). Throws InputError(source, ...) when it cannot.
SocketAddress resolve_udp_address(const UdpAddress& address, const std::string& source);

/// True when `a` and `b` are the same host and port: an IPv4 address and its IPv4-mapped
/// IPv6 form (::ffff:a.b.c.d, what a dual-stack socket reports) are the same. Never
/// allocates or throws (the force thread asks it of every datagram).
bool same_endpoint(const SocketAddress& a, const SocketAddress& b) noexcept;

/// "127.0.0.1:47002" or "[::1]:47002" (for reports; "?" when it cannot say).
std::string endpoint_text(const SocketAddress& address);

class UdpSocket {
 public:
  /// A socket bound to `local` (port 0: a free port the system picks). Throws
  /// InputError(source, "cannot listen on HOST:PORT: <reason>") when it cannot.
  static UdpSocket bound(const UdpAddress& local, const std::string& source);

  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;
  ~UdpSocket();

  /// The port it is bound to.
  std::uint16_t local_port() const;

  /// One waiting datagram into `buffer`: returns its real length (more than `capacity` when
  /// it did not fit: only `capacity` bytes were kept), or -1 when none is waiting. Never
  /// blocks, allocates or throws. `from` (if not null) gets the sender.
  long receive(std::uint8_t* buffer, std::size_t capacity, SocketAddress* from) noexcept;

  /// Waits up to `timeout` for a datagram to arrive (nanosecond resolution; a thread asleep
  /// here wakes within the scheduler's latency of the arrival). True when one is waiting.
  bool wait_readable(std::chrono::nanoseconds timeout) const noexcept;

  /// Sends one datagram; false when the system refused it (the caller counts it).
  bool send_to(const std::uint8_t* data, std::size_t size, const SocketAddress& to) noexcept;

 private:
  explicit UdpSocket(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace hapvox::haptics
