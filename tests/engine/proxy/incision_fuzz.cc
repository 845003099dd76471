// Fuzz target for the incision file's parser (engine/proxy/incision_file.h): any bytes either
// parse into a usable cut (a positive, finite width and at least one triangle) or throw
// InputError whose message is one line naming the file; nothing else may escape, crash or hang.
//
// Built as a libFuzzer binary (incision_fuzz) where the compiler has -fsanitize=fuzzer:
// `incision_fuzz -max_total_time=60 CORPUS_DIR data/engine_incision.toml`. With
// HAPVOX_FUZZ_REPLAY (in proxy_tests, any compiler) a test feeds it seeded random mutations of
// the bundled file and of a triangles form.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "engine/errors.h"
#include "engine/proxy/incision_file.h"
#include "fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::string source = "fuzz.toml";
  try {
    const auto incision = hapvox::engine::proxy::parse_incision(text, source);
    if (!(std::isfinite(incision.width_mm) && incision.width_mm > 0)) std::abort();
    if (incision.cut.triangles_mm.empty()) std::abort();
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
#include "test_data.h"

namespace {

TEST(IncisionFuzz, MutationsOfIncisionFilesParseOrGiveOneLineErrors) {
  const std::string bundled =
      hapvox::testing::read_file(hapvox::testing::source_path("data/engine_incision.toml"));
  ASSERT_FALSE(bundled.empty());
  const std::string triangles =
      "width_mm = 2.5\nat_s = 0.5\ntriangles_mm = [[[0, 0, 0], [10, 0, 0], [0, 10, 0]],\n"
      "  [[10, 0, 0], [10, 10, 0], [0, 10, 0]]]\n";
  std::mt19937_64 rng(20261203);
  int parsed = 0, rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::string input = hapvox::testing::mutate(i % 2 ? bundled : triangles, rng);
    try {
      hapvox::engine::proxy::parse_incision(input, "fuzz.toml");
      ++parsed;
    } catch (const hapvox::InputError&) {
      ++rejected;
    }
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
  }
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 1000);
  std::printf("incision fuzz corpus: %d parsed, %d rejected\n", parsed, rejected);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
