// Fuzz target for the sculpting window's input scripts (haptics/pointer_script.h): any text
// is a list of events in time order with finite numbers, or one InputError line naming the
// source.
//
// Built as a libFuzzer binary (pointer_script_fuzz) where the compiler has
// -fsanitize=fuzzer (clang). With HAPVOX_FUZZ_REPLAY (in haptics_tests, any compiler) a test
// feeds it seeded random mutations of a script.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/errors.h"
#include "fuzz_check.h"
#include "haptics/pointer_script.h"

namespace {

int fuzz_pointer_script(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string source = "fuzz.script";
  try {
    const auto events = hapvox::haptics::parse_pointer_script(text, source);
    double last = 0.0;
    for (const auto& e : events) {
      if (!std::isfinite(e.time_s) || e.time_s < last || !std::isfinite(e.x_px) ||
          !std::isfinite(e.y_px) || !(e.over_s >= 0.0) || !std::isfinite(e.wheel_steps)) {
        std::abort();
      }
      last = e.time_s;
    }
  } catch (const hapvox::InputError& e) {
    hapvox::testing::abort_unless_one_line_error(e, source);
  }
  return 0;
}

}  // namespace

#ifndef HAPVOX_FUZZ_REPLAY
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return fuzz_pointer_script(data, size);
}
#endif

#ifdef HAPVOX_FUZZ_REPLAY

#include <gtest/gtest.h>

#include <random>

#include "fuzz_mutate.h"

namespace {

const char kScript[] =
    "# a groove\n"
    "0.2 move 100 120\n"
    "0.3 press\n"
    "0.3 move 300 120 1.5\n"
    "1.0 wheel 2\n"
    "1.1 key space down\n"
    "1.2 key space up\n"
    "2.0 release\n"
    "2.1 screenshot groove.png\n"
    "2.2 quit\n";

TEST(PointerScriptFuzz, MutationsOfAScriptParseOrGiveOneLineErrors) {
  std::mt19937_64 rng(20261204);
  int parsed = 0, rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::string input = hapvox::testing::mutate(kScript, rng);
    try {
      hapvox::haptics::parse_pointer_script(input, "fuzz.script");
      ++parsed;
    } catch (const hapvox::InputError&) {
      ++rejected;
    }
    fuzz_pointer_script(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
  }
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 1000);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
