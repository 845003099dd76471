#pragma once
// Budgets for what an input may make hapvox allocate (docs/formats.md, "Limits"): a header
// or a trace can declare gigabytes in a few bytes, so every reader compares what the input
// implies with these limits before it allocates, and refuses it with one line naming the
// file, the limit and the flag that raises it.
//
// One set per process: the command line sets them once from its flags (tools/input_limits.cc)
// before anything is read; embedders get the defaults. Header-only, so every reader and fuzz
// target that includes it shares the one copy without linking anything new.

#include <cstdint>
#include <cstdio>
#include <string>

#include "engine/errors.h"

namespace hapvox::engine {

struct InputLimits {
  /// --max-input-mb: a volume's samples once decoded (4 bytes each, 8 for float64: what
  /// hapvox holds), and the bytes of a text input (a CSV trace, a TOML file), in MiB.
  std::uint64_t max_input_mb = 2048;
  /// --max-trace-rows: the samples a trace file declares or holds, and the ticks it makes
  /// on the loop's clock (its time span times the loop rate).
  std::uint64_t max_trace_rows = 50'000'000;
  /// --max-sweep-rows: the replays a sweep manifest describes (its grid's product plus its
  /// explicit rows).
  std::uint64_t max_sweep_rows = 100'000;

  std::uint64_t max_input_bytes() const { return max_input_mb << 20; }
};

/// The process's limits (the defaults until the command line sets them).
inline InputLimits& input_limits() {
  static InputLimits limits;
  return limits;
}

/// "over the limit of LIMIT UNIT (raise it with FLAG)": the end of every over-limit message.
inline std::string over_limit(std::uint64_t limit, const std::string& unit,
                              const std::string& flag) {
  return "over the limit of " + std::to_string(limit) + " " + unit + " (raise it with " + flag +
         ")";
}

/// Megabytes (MiB) in `bytes`, rounded up, for messages.
inline std::uint64_t megabytes(std::uint64_t bytes) { return (bytes + (1u << 20) - 1) >> 20; }

/// Throws InputError(source, WHAT + " " + N + " rows, " + over_limit(...)) when `rows` passes
/// --max-trace-rows. `what` says where the rows come from ("dataset 't' declares").
inline void check_trace_rows(double rows, const std::string& source, const std::string& what) {
  const std::uint64_t limit = input_limits().max_trace_rows;
  if (!(rows <= static_cast<double>(limit))) {
    char count[32];
    std::snprintf(count, sizeof count, "%.0f", rows);
    throw InputError(
        source, what + " " + count + " rows, " + over_limit(limit, "rows", "--max-trace-rows"));
  }
}

/// Throws InputError(source, "holds N MB, " + over_limit(...)) when a text input of `bytes`
/// passes --max-input-mb.
inline void check_text_bytes(std::uint64_t bytes, const std::string& source) {
  const InputLimits& limits = input_limits();
  if (bytes > limits.max_input_bytes()) {
    throw InputError(source, "holds " + std::to_string(megabytes(bytes)) + " MB, " +
                                 over_limit(limits.max_input_mb, "MB", "--max-input-mb"));
  }
}

}  // namespace hapvox::engine
