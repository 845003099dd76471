// SHA256_Init/Update/Final are deprecated in OpenSSL 3 but are the only allocation-free
// SHA-256 it offers (bridge_key.h says why): used knowingly, without the warnings.
#define OPENSSL_SUPPRESS_DEPRECATED

#include "haptics/bridge_key.h"

#include <openssl/crypto.h>
#include <openssl/sha.h>

#include <array>
#include <cstring>

#include "engine/errors.h"
#include "engine/text_file.h"

namespace hapvox::haptics {
namespace {

static_assert(sizeof(SHA256_CTX) <= 128, "BridgeKey::kStateBytes must hold a SHA256_CTX");
static_assert(static_cast<std::size_t>(SHA256_DIGEST_LENGTH) == kBridgeTagBytes);

constexpr std::size_t kBlockBytes = SHA256_CBLOCK;  // 64

// The SHA-256 state after hashing one block: the key XOR `pad`, as RFC 2104 begins HMAC.
SHA256_CTX padded_state(const std::array<unsigned char, kBlockBytes>& key_block,
                        unsigned char pad) {
  std::array<unsigned char, kBlockBytes> block;
  for (std::size_t i = 0; i < kBlockBytes; ++i) block[i] = key_block[i] ^ pad;
  SHA256_CTX state;
  SHA256_Init(&state);
  SHA256_Update(&state, block.data(), block.size());
  OPENSSL_cleanse(block.data(), block.size());
  return state;
}

}  // namespace

BridgeKey::BridgeKey(std::string_view key_bytes) {
  std::array<unsigned char, kBlockBytes> key_block{};  // the key, zero-padded to a block
  if (key_bytes.size() > kBlockBytes) {
    SHA256(reinterpret_cast<const unsigned char*>(key_bytes.data()), key_bytes.size(),
           key_block.data());
  } else if (!key_bytes.empty()) {
    std::memcpy(key_block.data(), key_bytes.data(), key_bytes.size());
  }
  SHA256_CTX inner = padded_state(key_block, 0x36);
  SHA256_CTX outer = padded_state(key_block, 0x5c);
  std::memcpy(inner_, &inner, sizeof inner);
  std::memcpy(outer_, &outer, sizeof outer);
  OPENSSL_cleanse(&inner, sizeof inner);
  OPENSSL_cleanse(&outer, sizeof outer);
  OPENSSL_cleanse(key_block.data(), key_block.size());
}

BridgeKey BridgeKey::from_file(const std::string& path) {
  std::string bytes = engine::read_text_file(path);  // "cannot open file", "is a directory"
  if (bytes.empty()) {
    throw InputError(path,
                     "the key file is empty (it holds the shared key's bytes, e.g. "
                     "32 from /dev/urandom)");
  }
  BridgeKey key(bytes);
  OPENSSL_cleanse(bytes.data(), bytes.size());
  return key;
}

BridgeKey::~BridgeKey() {
  OPENSSL_cleanse(inner_, sizeof inner_);
  OPENSSL_cleanse(outer_, sizeof outer_);
}

void BridgeKey::sign(const std::uint8_t* data, std::size_t size, std::uint8_t* tag) const noexcept {
  // HMAC = H(key ^ opad || H(key ^ ipad || data)), each H resumed from its saved state.
  SHA256_CTX state;
  std::memcpy(&state, inner_, sizeof state);
  SHA256_Update(&state, data, size);
  unsigned char inner_digest[SHA256_DIGEST_LENGTH];
  SHA256_Final(inner_digest, &state);
  std::memcpy(&state, outer_, sizeof state);
  SHA256_Update(&state, inner_digest, sizeof inner_digest);
  SHA256_Final(tag, &state);
}

bool BridgeKey::verify(const std::uint8_t* data, std::size_t size,
                       const std::uint8_t* tag) const noexcept {
  std::uint8_t expected[kBridgeTagBytes];
  sign(data, size, expected);
  return CRYPTO_memcmp(expected, tag, kBridgeTagBytes) == 0;
}

}  // namespace hapvox::haptics
