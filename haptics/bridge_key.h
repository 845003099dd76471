#pragma once
// The device bridge's shared key (`--device-key FILE`, docs/formats.md "Device bridge
// packets"): with one, every packet both ways ends in a 32-byte HMAC-SHA256 tag (RFC 2104,
// full length) over the bytes before it, and a packet whose tag is wrong or missing is
// refused. It proves who sent a packet (a host that knows the key) and that nothing changed
// on the way; it hides nothing (no encryption), and a recorded packet sent again is held off
// by the sequence window, not by the tag (haptics/bridge_sequence.h).
//
// The force thread verifies each position packet and tags each answer, so sign() and
// verify() never allocate, lock, throw or do I/O. OpenSSL 3.0's EVP interfaces cannot do
// that: EVP_MAC_init(ctx, NULL, 0, NULL) on a keyed HMAC context re-initialises through
// EVP_MD_CTX_copy_ex, whose provider dupctx mallocs a digest context (HMAC_Final a second:
// 2 allocations a tag, counted with CRYPTO_set_mem_functions on Debian 12's 3.0.19), and
// the one-shot HMAC() fetches and allocates a whole context per call (13 a tag). So the
// key's inner and outer SHA-256 states (key XOR ipad / opad, hashed once) are made here,
// at construction, and each tag copies them (plain structs) and runs libcrypto's SHA-256
// on the stack (SHA256_Update / SHA256_Final: deprecated in OpenSSL 3 in favour of EVP,
// still in its ABI; 0 allocations). The tests check the tags against RFC 4231's vectors
// and OpenSSL's HMAC(), and count OpenSSL's allocations on the force thread: none.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace hapvox::haptics {

/// HMAC-SHA256's full output, appended to every packet of a keyed session.
inline constexpr std::size_t kBridgeTagBytes = 32;

class BridgeKey {
 public:
  /// A key of these bytes (any length: a key longer than SHA-256's 64-byte block is hashed
  /// first, as RFC 2104 says).
  explicit BridgeKey(std::string_view key_bytes);
  /// The bytes of the file at `path`, exactly as they are (a trailing newline is part of the
  /// key). Throws InputError(path, ...) when it is missing, a directory, unreadable or empty.
  static BridgeKey from_file(const std::string& path);

  BridgeKey(const BridgeKey&) = default;
  BridgeKey& operator=(const BridgeKey&) = default;
  ~BridgeKey();  // overwrites the key's states

  /// HMAC-SHA256(key, data[0, size)) into tag[0, kBridgeTagBytes). No allocation, lock,
  /// exception or I/O.
  void sign(const std::uint8_t* data, std::size_t size, std::uint8_t* tag) const noexcept;
  /// True when `tag` (kBridgeTagBytes) is data's, compared in constant time.
  bool verify(const std::uint8_t* data, std::size_t size, const std::uint8_t* tag) const noexcept;

 private:
  // OpenSSL's SHA256_CTX after hashing the key XOR ipad (opad), kept as bytes so that this
  // header needs no OpenSSL header (bridge_key.cc checks that it fits).
  static constexpr std::size_t kStateBytes = 128;
  alignas(8) unsigned char inner_[kStateBytes] = {};
  alignas(8) unsigned char outer_[kStateBytes] = {};
};

}  // namespace hapvox::haptics
