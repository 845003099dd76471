#include "test_data.h"

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "engine/errors.h"

namespace hapvox::testing {

std::string source_path(const std::string& relative) {
  return (std::filesystem::path(HAPVOX_SOURCE_DIR) / relative).string();
}

std::string hapvox_binary() { return HAPVOX_BINARY; }

namespace {
// Unique to the running test: ctest runs tests in parallel.
std::string scratch_dir_name() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = "hapvox_test";
  if (info != nullptr) {
    name += std::string("_") + info->test_suite_name() + "_" + info->name();
  }
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  return (std::filesystem::temp_directory_path() / name).string();
}
}  // namespace

std::string scratch_dir() {
  const std::filesystem::path dir = scratch_dir_name();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

CommandResult run_hapvox(const std::string& args) { return run_hapvox_env("", args); }

CommandResult run_hapvox_env(const std::string& environment, const std::string& args) {
  // Beside the test's scratch directory, not in it: the test may look at that one. Each
  // call its own files: a test that runs two commands at once (a live replay and the device
  // program feeding it) had both write one file, and one's output overwrote the other's.
  static std::atomic<int> calls{0};
  const std::string base = scratch_dir_name() + "_" + std::to_string(calls++);
  const std::string out = base + "_stdout.txt";
  const std::string err = base + "_stderr.txt";
  const std::string command =
      environment + " " + hapvox_binary() + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(command.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_file(out);
  r.err = read_file(err);
  return r;
}

std::string input_error_of(const std::function<void()>& body) {
  try {
    body();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

}  // namespace hapvox::testing
