#pragma once
// A single-writer seqlock over a trivially copyable value: the writer never waits, a reader
// retries a read the writer tore. The value travels as 64-bit words, each an atomic, with
// sequentially consistent accesses (as ToolStateMailbox, haptics/render_feed.h): one total
// order makes the argument trivial and ThreadSanitizer sees it whole.

#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace hapvox::haptics {

template <class T>
class Seqlock {
  static_assert(std::is_trivially_copyable_v<T>, "a seqlock copies its value as bytes");
  static constexpr std::size_t kWords = (sizeof(T) + 7) / 8;

 public:
  Seqlock() { write(T{}); }

  /// The one writer: wait-free, no allocation.
  void write(const T& value) noexcept {
    std::uint64_t words[kWords] = {};
    std::memcpy(words, &value, sizeof(T));
    const std::uint64_t s = sequence_.load();
    sequence_.store(s + 1);
    for (std::size_t i = 0; i < kWords; ++i) words_[i].store(words[i]);
    sequence_.store(s + 2);
  }

  /// Any reader: the latest complete value.
  T read() const noexcept {
    std::uint64_t words[kWords];
    while (true) {
      const std::uint64_t before = sequence_.load();
      if (before & 1u) continue;  // mid-update: the writer is a few stores from done
      for (std::size_t i = 0; i < kWords; ++i) words[i] = words_[i].load();
      if (sequence_.load() == before) break;
    }
    T value;
    std::memcpy(&value, words, sizeof(T));
    return value;
  }

 private:
  std::atomic<std::uint64_t> sequence_{0};  // odd while the writer is mid-update
  std::atomic<std::uint64_t> words_[kWords] = {};
};

}  // namespace hapvox::haptics
