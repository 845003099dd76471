#pragma once
// Loopback ports for tests that run a bridge (tests/tools): one free now, and whether a
// process listens on one yet.

#include <cstdint>

#include "engine/errors.h"
#include "haptics/udp_socket.h"

namespace hapvox::testing {

/// A loopback port free now (the system's pick), for a process to listen on next.
inline std::uint16_t free_port() {
  return haptics::UdpSocket::bound({"127.0.0.1", 0}, "test").local_port();
}

/// True once something listens on `port` (binding it fails).
inline bool listening(std::uint16_t port) {
  try {
    haptics::UdpSocket::bound({"127.0.0.1", port}, "test");
    return false;
  } catch (const InputError&) {
    return true;
  }
}

}  // namespace hapvox::testing
