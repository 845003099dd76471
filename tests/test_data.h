#pragma once
// Paths to data shipped in the repository (data/, traces/), scratch space for tests, and
// the message of an InputError for asserting it in full.

#include <functional>
#include <string>

namespace hapvox::testing {

/// HAPVOX_SOURCE_DIR + "/" + relative.
std::string source_path(const std::string& relative);
/// The hapvox executable built alongside the tests.
std::string hapvox_binary();
/// A fresh, empty directory unique to the running test.
std::string scratch_dir();
/// The bytes of a file ("" when it cannot be read).
std::string read_file(const std::string& path);
/// Writes `bytes` to `path`, replacing what was there.
void write_file(const std::string& path, const std::string& bytes);

/// What a run of the hapvox executable printed and returned.
struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};
/// Runs `hapvox ARGS` (a shell command line), capturing stdout and stderr in files unique
/// to the running test (ctest runs tests in parallel).
CommandResult run_hapvox(const std::string& args);
/// The same with environment assignments ("NAME=value ...") before the command.
CommandResult run_hapvox_env(const std::string& environment, const std::string& args);

/// Runs `body`, expects an InputError, and returns its what() ("" and a failure when none).
std::string input_error_of(const std::function<void()>& body);

}  // namespace hapvox::testing
