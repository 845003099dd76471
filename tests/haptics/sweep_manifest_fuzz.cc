// Fuzz target for sweep manifests (haptics/sweep_manifest.h): any text is a manifest of at
// least one row, each with a trace, a volume and a known model, its options sorted, none of
// them a flag the sweep sets; or one InputError line naming the source.
//
// Built as a libFuzzer binary (sweep_manifest_fuzz) where the compiler has -fsanitize=fuzzer
// (clang). With HAPVOX_FUZZ_REPLAY (in haptics_tests, any compiler) a test feeds it seeded
// random mutations of a manifest.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/errors.h"
#include "fuzz_check.h"
#include "haptics/sweep_manifest.h"

namespace {

int fuzz_sweep_manifest(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string source = "fuzz.toml";
  try {
    const hapvox::haptics::SweepManifest m =
        hapvox::haptics::parse_sweep_manifest(text, source, "/base");
    if (m.rows.empty()) std::abort();
    for (const auto& row : m.rows) {
      if (row.trace.empty() || row.volume.empty() || row.line < 1) std::abort();
      if (row.model != "voxel" && row.model != "fem") std::abort();
      if (!std::is_sorted(row.options.begin(), row.options.end())) std::abort();
      for (const auto& [name, value] : row.options) {
        if (name.empty() || name.front() == '-' || name == "output" || name == "volume") {
          std::abort();
        }
      }
    }
  } catch (const hapvox::InputError& e) {
    hapvox::testing::abort_unless_one_line_error(e, source);
  }
  return 0;
}

}  // namespace

#ifndef HAPVOX_FUZZ_REPLAY
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return fuzz_sweep_manifest(data, size);
}
#endif

#ifdef HAPVOX_FUZZ_REPLAY

#include <gtest/gtest.h>

#include <random>

#include "fuzz_mutate.h"

namespace {

const char kManifest[] =
    "traces = ['a.csv', 'b.csv']\n"
    "volumes = ['block:dims=32', 'ct.nrrd']\n"
    "models = ['voxel']\n"
    "materials = ['', 'soft.toml']\n"
    "[options]\n"
    "tool-diameter-mm = [4, 8.5]\n"
    "plastic = [false, true]\n"
    "[[row]]\n"
    "trace = 'c.csv'\n"
    "volume = 'four-spheres'\n"
    "model = 'fem'\n"
    "options = { interaction = 'grab', fem-every-ticks = 5 }\n";

TEST(SweepManifestFuzz, MutationsOfAManifestParseOrGiveOneLineErrors) {
  std::mt19937_64 rng(20261205);
  int parsed = 0, rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::string input = hapvox::testing::mutate(kManifest, rng);
    try {
      hapvox::haptics::parse_sweep_manifest(input, "fuzz.toml", "/base");
      ++parsed;
    } catch (const hapvox::InputError&) {
      ++rejected;
    }
    fuzz_sweep_manifest(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
  }
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 1000);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
