#pragma once
// Counts allocations per thread, so a test can prove that code allocated nothing: replaces
// operator new and delete in every replaceable form, so no allocation bypasses the count and
// every pointer is freed by the family that made it (sanitizers check that).
//
// Include it in exactly one .cc of a test binary: the replacements are program-wide, and a
// second copy is a multiple-definition link error. malloc itself is not counted here; a
// binary linked with -Wl,--wrap=malloc counts it by defining __wrap_malloc (fem_tests does,
// in contact_compliance_test.cc) to bump `allocations_on_this_thread`.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#include "alloc_count.h"

// GCC cannot see that these replacements pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace hapvox::testing {

namespace alloc_counter_detail {
inline void* counted_alloc(std::size_t size, std::size_t align) {
  ++allocations_on_this_thread;
  if (size == 0) size = 1;
  if (align <= alignof(std::max_align_t)) return std::malloc(size);
  return std::aligned_alloc(align, (size + align - 1) / align * align);
}
inline void* counted_or_throw(std::size_t size, std::size_t align) {
  if (void* p = counted_alloc(size, align)) return p;
  throw std::bad_alloc();
}
}  // namespace alloc_counter_detail

}  // namespace hapvox::testing

// Replacement functions may not be inline, hence the one-.cc rule above.
void* operator new(std::size_t n) {
  return hapvox::testing::alloc_counter_detail::counted_or_throw(n, 0);
}
void* operator new[](std::size_t n) {
  return hapvox::testing::alloc_counter_detail::counted_or_throw(n, 0);
}
void* operator new(std::size_t n, std::align_val_t a) {
  return hapvox::testing::alloc_counter_detail::counted_or_throw(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return hapvox::testing::alloc_counter_detail::counted_or_throw(n, static_cast<std::size_t>(a));
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return hapvox::testing::alloc_counter_detail::counted_alloc(n, 0);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return hapvox::testing::alloc_counter_detail::counted_alloc(n, 0);
}
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return hapvox::testing::alloc_counter_detail::counted_alloc(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return hapvox::testing::alloc_counter_detail::counted_alloc(n, static_cast<std::size_t>(a));
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
