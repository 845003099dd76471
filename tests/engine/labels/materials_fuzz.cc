// Fuzz target for the materials parser: any bytes either parse or throw InputError whose
// message is one line naming the file; nothing else may escape, crash or hang.
//
// Built as a libFuzzer binary (materials_fuzz) where the compiler has -fsanitize=fuzzer
// (clang): `materials_fuzz -max_total_time=60 CORPUS_DIR data/four_spheres.toml`. With
// HAPVOX_FUZZ_REPLAY (in label_tests, any compiler) a test feeds it the bundled files and
// thousands of seeded random mutations of it (byte flips, inserts, deletes, splices).

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "engine/errors.h"
#include "engine/labels/materials.h"
#include "fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::string source = "fuzz.toml";
  try {
    const auto materials = hapvox::engine::labels::parse_materials(text, source);
    if (materials.materials.empty()) std::abort();  // the parser promises at least one
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

using hapvox::testing::mutate;

TEST(MaterialsFuzz, MutationsOfTheBundledFileParseOrGiveOneLineErrors) {
  // The bundled files: the proxy model's (fixed regions) and the voxel model's (yield).
  const std::string seeds[2] = {
      hapvox::testing::read_file(hapvox::testing::source_path("data/four_spheres.toml")),
      hapvox::testing::read_file(hapvox::testing::source_path("data/engine_tissues.toml"))};
  ASSERT_FALSE(seeds[0].empty());
  ASSERT_FALSE(seeds[1].empty());
  std::mt19937_64 rng(20240509);
  int parsed = 0;
  int rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::string input = mutate(seeds[i % 2], rng);
    try {
      hapvox::engine::labels::parse_materials(input, "fuzz.toml");
      ++parsed;
    } catch (const hapvox::InputError&) {
      ++rejected;
    }
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
  }
  // Both outcomes occur: the mutations reach past the syntax checks into the schema's.
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 1000);
  std::printf("materials fuzz corpus: %d parsed, %d rejected\n", parsed, rejected);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
