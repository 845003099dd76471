// The command line's shared guards (tools/hapvox.cc) end to end: errors are one printable
// line whatever a file holds, and an unknown command is an error, with or without --help.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "engine/volume_io.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::scratch_dir;
using testing::source_path;
using Result = testing::CommandResult;

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// `hapvox ARGS` run in `dir`, so that paths can be given relative to it.
Result run_in(const std::string& dir, const std::string& args) {
  return testing::run_hapvox_env("cd '" + dir + "' &&", args);
}

void expect_error_in(const std::string& dir, const std::string& args, const std::string& line) {
  const Result r = run_in(dir, args);
  EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.out << r.err;
  EXPECT_EQ(r.err, "hapvox: error: " + line + "\n") << args;
}

bool printable_ascii(const std::string& text) {
  return std::all_of(text.begin(), text.end(), [](char c) { return c >= 0x20 && c <= 0x7e; });
}

// The one line of stderr, checked: printable ASCII only and at most `max_size` long.
void expect_one_printable_line(const Result& r, std::size_t max_size) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.back(), '\n');
  const std::string line = r.err.substr(0, r.err.size() - 1);
  EXPECT_TRUE(printable_ascii(line)) << line;
  EXPECT_LE(line.size(), max_size) << line;
}

std::string random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 random(seed);
  std::string bytes(n, '\0');
  for (char& c : bytes) c = static_cast<char>(random() & 0xff);
  return bytes;
}

// Issue 8 point 8: a binary file given as a CSV trace echoed its bytes into the error.
TEST(CliErrors, ABinaryTraceGivesOnePrintableLine) {
  const std::string dir = scratch_dir();
  const std::string binary = random_bytes(4096, 8);
  ASSERT_NE(binary.find('\0'), std::string::npos);
  write_file(dir + "/bin.csv", binary);
  for (const std::string& command :
       {"replay " + dir + "/bin.csv --volume block -o " + dir + "/s.h5",
        "info " + dir + "/bin.csv"}) {
    const Result r = testing::run_hapvox(command);
    expect_one_printable_line(r, 200 + dir.size());
    EXPECT_EQ(r.err, "hapvox: error: " + dir +
                         "/bin.csv: not a CSV text file (it holds NUL bytes: binary data?)\n");
  }
  // Without NUL bytes the header is read, and echoed as printable text, cut short.
  std::string no_nul = binary;
  std::replace(no_nul.begin(), no_nul.end(), '\0', '\1');
  write_file(dir + "/bytes.csv", no_nul);
  const Result r =
      testing::run_hapvox("replay " + dir + "/bytes.csv --volume block -o " + dir + "/s.h5");
  expect_one_printable_line(r, 200 + dir.size());
  EXPECT_EQ(r.err.rfind("hapvox: error: " + dir + "/bytes.csv: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("\\x"), std::string::npos) << r.err;   // bytes shown as \xNN
  EXPECT_NE(r.err.find("...)"), std::string::npos) << r.err;  // and cut
  EXPECT_FALSE(fs::exists(dir + "/s.h5"));
}

TEST(CliErrors, FieldsAndNamesAreEscapedAndCut) {
  const std::string dir = scratch_dir();
  write_file(dir + "/esc.csv", "t,x,y,z\n0,1,2,3\n1,\x1b[31mred\x01,2,3\n");
  expect_error_in(dir, "replay esc.csv --volume block -o s.h5",
                  "esc.csv: line 3: column 'x': not a number: '\\x1B[31mred\\x01'");
  write_file(dir + "/long.csv", "t,x,y,z\n0,1,2,3\n1," + std::string(500, 'A') + ",2,3\n");
  expect_error_in(dir, "replay long.csv --volume block -o s.h5",
                  "long.csv: line 3: column 'x': not a number: '" + std::string(40, 'A') + "...'");
  // The name of the file itself, echoed by `hapvox: error:` as it is printed.
  expect_error_in(dir, "replay 'a\x1b[2Jb.csv' --volume block -o s.h5",
                  "a\\x1B[2Jb.csv: cannot open file");
}

// Issue 8: `hapvox no-such-command --help` printed the help and exited 0.
TEST(CliCommands, AnUnknownCommandIsAnErrorWithOrWithoutHelp) {
  for (const char* args : {"no-such-command --help", "no-such-command", "no-such-command -h",
                           "--help no-such-command", "no-such-command replay"}) {
    const Result r = testing::run_hapvox(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(r.err, "hapvox: error: no-such-command: unknown command (see hapvox --help)\n")
        << args;
    EXPECT_EQ(r.out, "") << args;
  }
  for (const char* args : {"trace no-such --help", "trace no-such -o x.csv"}) {
    const Result r = testing::run_hapvox(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(r.err, "hapvox: error: no-such: unknown command (see hapvox trace --help)\n") << args;
  }
  const Result bench = testing::run_hapvox("bench no-such --help");
  EXPECT_EQ(bench.exit_code, 2);
  EXPECT_EQ(bench.err, "hapvox: error: no-such: unknown command (see hapvox bench --help)\n");
  // Known commands still answer --help, and a positional argument is not a command.
  for (const char* args : {"--help", "trace --help", "trace make --help", "bench force --help"}) {
    const Result r = testing::run_hapvox(args);
    EXPECT_EQ(r.exit_code, 0) << args << r.err;
    EXPECT_NE(r.out.find("Usage:"), std::string::npos) << args;
  }
  EXPECT_EQ(testing::run_hapvox("info block").exit_code, 0);
}
}  // namespace
}  // namespace hapvox
