#pragma once
// Shared by the API's tests: the bundled engine CT and press trace, and what `hapvox replay`
// made of them.

#include <gtest/gtest.h>
#include <hapvox/hapvox.h>

#include <cstring>
#include <string>

#include "test_data.h"

namespace hapvox::testing {

inline const std::string kEngineCt = "data/engine_256x256x128_uint8.nrrd";
inline const std::string kEnginePress = "traces/engine_press.csv";

/// `hapvox replay TRACE --volume VOLUME -o DIR/cli.h5 FLAGS` (asserting it succeeded),
/// read back. DIR: the test's scratch_dir(), made once (each call empties it).
inline Session cli_replay(const std::string& dir, const std::string& trace,
                          const std::string& volume, const std::string& flags = "") {
  const std::string output = dir + "/cli.h5";
  const CommandResult run = run_hapvox("replay " + source_path(trace) + " --volume " +
                                       source_path(volume) + " -q -o " + output + " " + flags);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  return Session::open(output);
}

/// The same doubles, bit for bit (NaN equals NaN, 0 differs from -0).
inline ::testing::AssertionResult same_bits(const Dataset& a, const Dataset& b) {
  if (a.shape != b.shape) return ::testing::AssertionFailure() << "shapes differ";
  for (std::size_t i = 0; i < a.values.size(); ++i) {
    if (std::memcmp(&a.values[i], &b.values[i], sizeof(double)) != 0) {
      return ::testing::AssertionFailure()
             << "value " << i << ": " << a.values[i] << " vs " << b.values[i];
    }
  }
  return ::testing::AssertionSuccess();
}

/// The line `hapvox` printed on stderr after "hapvox: error: " (its trailing newline cut).
inline std::string cli_error_line(const CommandResult& run) {
  const std::string prefix = "hapvox: error: ";
  const std::size_t at = run.err.find(prefix);
  if (at == std::string::npos) return "(no error line in: " + run.err + ")";
  std::string line = run.err.substr(at + prefix.size());
  return line.substr(0, line.find('\n'));
}

}  // namespace hapvox::testing
