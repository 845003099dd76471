#pragma once
// tbb::parallel_reduce with its fork and join made visible to ThreadSanitizer.
//
// Debian's libtbb is not built with TSan, so TSan cannot see that a task starts after the
// thread that spawned it wrote its inputs, nor that parallel_reduce returns only after
// every task ended. A buffer written by a worker and read by the caller afterwards then
// looks racy (CI saw ProxyResampler's texels reported so, with the worker's stack lost).
// These annotations state exactly those two edges, fork -> each task and each task ->
// join, and no edge between tasks, so a real race between two tasks is still reported.
// Outside TSan builds they compile to nothing.

#include <tbb/parallel_reduce.h>

#if defined(__SANITIZE_THREAD__)
#include <sanitizer/tsan_interface.h>
#endif

namespace hapvox::engine {
namespace detail {

inline void tsan_release([[maybe_unused]] const void* token) {
#if defined(__SANITIZE_THREAD__)
  __tsan_release(const_cast<void*>(token));
#endif
}

inline void tsan_acquire([[maybe_unused]] const void* token) {
#if defined(__SANITIZE_THREAD__)
  __tsan_acquire(const_cast<void*>(token));
#endif
}

}  // namespace detail

/// tbb::parallel_reduce(range, identity, body, join), the result and scheduling unchanged.
template <class Range, class Value, class Body, class Join>
Value parallel_reduce(const Range& range, const Value& identity, const Body& body,
                      const Join& join) {
  const char fork = 0;  // two distinct addresses TSan uses as synchronisation objects
  const char done = 0;
  detail::tsan_release(&fork);
  const Value result = tbb::parallel_reduce(
      range, identity,
      [&](const Range& part, Value value) {
        detail::tsan_acquire(&fork);
        value = body(part, value);
        detail::tsan_release(&done);
        return value;
      },
      join);
  detail::tsan_acquire(&done);
  return result;
}

}  // namespace hapvox::engine
