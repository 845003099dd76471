// Fuzz target for the trace text parsers (CSV and H3D DeviceLog): any bytes either parse
// into a trace (at least two samples, increasing times, finite values, unit orientations)
// that resamples within its tick budget, or throw InputError whose message is one line
// naming the source; nothing else may escape, crash or hang. The first byte picks the
// parser (even: CSV with orientation columns, odd: DeviceLog).
//
// Built as a libFuzzer binary (trace_fuzz) where the compiler has -fsanitize=fuzzer (clang):
// `trace_fuzz -max_total_time=60 CORPUS_DIR traces/`. With HAPVOX_FUZZ_REPLAY (in
// haptics_tests, any compiler) a test feeds it seeded random mutations of a CSV trace with
// orientation and of a DeviceLog.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "force_safety_check.h"
#include "fuzz_check.h"
#include "haptics/trace.h"
#include "haptics/trace_h3d.h"
#include "haptics/trace_resample.h"

namespace {

void check_trace(const hapvox::haptics::Trace& trace) {
  if (trace.time_s.size() < 2 || trace.position_mm.size() != trace.time_s.size()) std::abort();
  if (!trace.orientation.empty() && trace.orientation.size() != trace.time_s.size()) std::abort();
  for (std::size_t i = 0; i < trace.time_s.size(); ++i) {
    if (!std::isfinite(trace.time_s[i]) || !trace.position_mm[i].allFinite()) std::abort();
    if (i > 0 && !(trace.time_s[i] > trace.time_s[i - 1])) std::abort();
  }
  for (const auto& q : trace.orientation) {
    if (!(std::abs(q.norm() - 1.0) < 1e-9)) std::abort();
  }
  // Whatever positions it holds, the forces they make are safe (one sample a tick).
  hapvox::testing::abort_unless_forces_safe(trace.position_mm);
}

// A parsed trace is resampled too, under a budget of 100,000 ticks, so that a time span too
// long for it is one line naming the trace, never gigabytes.
void check_resampled(const hapvox::haptics::Trace& trace, const std::string& source) {
  hapvox::engine::InputLimits& limits = hapvox::engine::input_limits();
  const hapvox::engine::InputLimits saved = limits;
  limits.max_trace_rows = 100'000;
  try {
    const auto ticks = hapvox::haptics::resample(trace, {}, source);
    limits = saved;
    if (ticks.time_s.empty() || ticks.time_s.size() > 100'000) std::abort();
  } catch (...) {
    limits = saved;
    throw;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool device_log = (data[0] & 1) != 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::string source = "fuzz.trace";
  try {
    hapvox::haptics::Trace trace;
    if (device_log) {
      trace = hapvox::haptics::parse_h3d_device_log(text, source);
    } else {
      hapvox::haptics::TraceColumns columns;
      columns.orientation = {"qw", "qx", "qy", "qz"};
      trace = hapvox::haptics::parse_csv_trace(text, source, columns);
    }
    check_trace(trace);
    check_resampled(trace, source);
  } catch (const hapvox::InputError& e) {
    hapvox::testing::abort_unless_one_line_error(e, source);
  }
  return 0;
}

#ifdef HAPVOX_FUZZ_REPLAY

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "fuzz_mutate.h"

namespace {

const char kCsv[] =
    "t,x,y,z,qw,qx,qy,qz\n"
    "0,1,2,3,1,0,0,0\n"
    "0.001,1.5,2,3,0.9238795,0,0,0.3826834\n"
    "0.002,2,2.5,3,0.7071068,0,0,0.7071068\n";

const char kDeviceLog[] =
    "TIME POSITION ORIENTATION VELOCITY BUTTONS FORCE TORQUE\n"
    "0.00000 0.01000 0.02000 0.03000 0.00000 0.00000 1.00000 0.00000 0.00000 0.00000 0.00000 "
    "0 0.00000 0.00000 0.00000 0.00000 0.00000 0.00000\n"
    "0.00100 0.01100 0.02000 0.03000 0.00000 0.00000 1.00000 1.57080 0.10000 0.00000 0.00000 "
    "1 0.00000 0.00000 0.50000 0.00000 0.00000 0.00000\n";

TEST(TraceFuzz, MutationsOfACsvAndADeviceLogParseOrGiveOneLineErrors) {
  std::mt19937_64 rng(20261203);
  int parsed = 0;
  int rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    const bool device_log = i % 2 == 1;
    const std::string input = std::string(1, device_log ? '\1' : '\0') +
                              hapvox::testing::mutate(device_log ? kDeviceLog : kCsv, rng);
    try {
      if (device_log) {
        hapvox::haptics::parse_h3d_device_log(input.substr(1), "fuzz.trace");
      } else {
        hapvox::haptics::TraceColumns columns;
        columns.orientation = {"qw", "qx", "qy", "qz"};
        hapvox::haptics::parse_csv_trace(input.substr(1), "fuzz.trace", columns);
      }
      ++parsed;
    } catch (const hapvox::InputError&) {
      ++rejected;
    }
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
  }
  // Both outcomes occur: the mutations reach past the header into the rows' checks.
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 1000);
  std::printf("trace fuzz corpus: %d parsed, %d rejected\n", parsed, rejected);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
