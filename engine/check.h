#pragma once
// Always-on invariant checks that print both operands (pbrt-style). For programming
// errors only; user input errors throw hapvox::InputError.

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

namespace hapvox::detail {

[[noreturn]] inline void check_failed(const char* file, int line, const std::string& what) {
  std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", file, line, what.c_str());
  std::abort();
}

template <typename A, typename B>
std::string check_operands(const char* expr, const A& a, const B& b) {
  std::ostringstream out;
  out << expr << " with " << a << " vs " << b;
  return out.str();
}

}  // namespace hapvox::detail

#define HAPVOX_CHECK(cond) \
  ((cond) ? (void)0 : ::hapvox::detail::check_failed(__FILE__, __LINE__, #cond))

#define HAPVOX_CHECK_OP(a, op, b)        \
  (((a)op(b))                            \
       ? (void)0                         \
       : ::hapvox::detail::check_failed( \
             __FILE__, __LINE__, ::hapvox::detail::check_operands(#a " " #op " " #b, (a), (b))))

#define HAPVOX_CHECK_EQ(a, b) HAPVOX_CHECK_OP(a, ==, b)
#define HAPVOX_CHECK_NE(a, b) HAPVOX_CHECK_OP(a, !=, b)
#define HAPVOX_CHECK_LT(a, b) HAPVOX_CHECK_OP(a, <, b)
#define HAPVOX_CHECK_LE(a, b) HAPVOX_CHECK_OP(a, <=, b)
#define HAPVOX_CHECK_GT(a, b) HAPVOX_CHECK_OP(a, >, b)
#define HAPVOX_CHECK_GE(a, b) HAPVOX_CHECK_OP(a, >=, b)
