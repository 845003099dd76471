#pragma once
// The per-thread allocation count that tests/alloc_counter.h's replacements of operator new
// (and a test binary's __wrap_malloc) bump. Include this one wherever a test reads it;
// alloc_counter.h itself goes in exactly one .cc of the binary.

#include <cstdint>

namespace hapvox::testing {

/// Allocations made on the calling thread since it started.
inline thread_local std::uint64_t allocations_on_this_thread = 0;

}  // namespace hapvox::testing
