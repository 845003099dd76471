// The command line's shared guards (tools/cli.cc, tools/hapvox.cc) end to end: outputs that
// would overwrite an input are refused, errors are one printable line whatever a file
// holds, and an unknown command is an error, with or without --help.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "engine/volume_io.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::read_file;
using testing::scratch_dir;
using testing::source_path;
using Result = testing::CommandResult;

using testing::write_file;

// `hapvox ARGS` run in `dir`, so that paths can be given relative to it.
Result run_in(const std::string& dir, const std::string& args) {
  return testing::run_hapvox_env("cd '" + dir + "' &&", args);
}

void expect_error_in(const std::string& dir, const std::string& args, const std::string& line) {
  const Result r = run_in(dir, args);
  EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.out << r.err;
  EXPECT_EQ(r.err, "hapvox: error: " + line + "\n") << args;
}

// Issue 8 point 7: `hapvox replay p.csv --volume block -o p.csv` overwrote the trace.
TEST(CliOutputs, AnOutputNamingAnInputIsRefusedAndTheInputKept) {
  const std::string dir = scratch_dir();
  write_file(dir + "/p.csv", read_file(source_path("traces/clay_stroke.csv")));
  write_file(dir + "/q.csv.partial", read_file(source_path("traces/clay_stroke.csv")));
  fs::create_symlink("p.csv", dir + "/link.csv");
  engine::write_nrrd(engine::generate_volume("block:dims=32"), dir + "/clay.nrrd");
  engine::write_vdb(engine::generate_volume("block:dims=32"), dir + "/clay.vdb");
  // A detached NRRD header and its data file.
  write_file(dir + "/d.raw", std::string(64, '\1'));
  write_file(dir + "/d.nhdr",
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n"
             "data file: d.raw\n\n");
  write_file(dir + "/frame_0002.png", "0 0 0 0 0\n1 1 1 1 1\n");  // a transfer function
  std::vector<std::string> inputs = {"p.csv", "q.csv.partial", "clay.nrrd",     "clay.vdb",
                                     "d.raw", "d.nhdr",        "frame_0002.png"};
  std::vector<std::string> before;
  for (const std::string& name : inputs) before.push_back(read_file(dir + "/" + name));

  const std::string trace = "replay p.csv --volume block:dims=32 ";
  expect_error_in(dir, trace + "-o p.csv", "p.csv: --output would overwrite the input trace p.csv");
  expect_error_in(dir, trace + "-o ./p.csv",
                  "./p.csv: --output would overwrite the input trace p.csv");
  expect_error_in(dir, trace + "-o " + dir + "/p.csv",
                  dir + "/p.csv: --output would overwrite the input trace p.csv");
  expect_error_in(dir, trace + "-o link.csv",
                  "link.csv: --output would overwrite the input trace p.csv");
  expect_error_in(dir, "replay link.csv --volume block -o p.csv",
                  "p.csv: --output would overwrite the input trace link.csv");
  expect_error_in(dir, "replay p.csv --volume block -o p.csv --realtime",
                  "p.csv: --output would overwrite the input trace p.csv");
  expect_error_in(dir, "check-timing p.csv --volume block -o p.csv",
                  "p.csv: --output would overwrite the input trace p.csv");
  // The session is written as q.csv.partial first.
  expect_error_in(dir, "replay q.csv.partial --volume block -o q.csv",
                  "q.csv: --output would overwrite the input trace q.csv.partial (written first "
                  "as q.csv.partial)");
  // Volumes, and --sculpt-out clay, which writes clay.vdb and clay.nrrd.
  expect_error_in(dir, "replay p.csv --volume clay.nrrd -o clay.nrrd",
                  "clay.nrrd: --output would overwrite the input volume clay.nrrd");
  expect_error_in(dir, "replay p.csv --volume clay.nrrd --plastic -o s.h5 --sculpt-out clay",
                  "clay.nrrd: --sculpt-out would overwrite the input volume clay.nrrd");
  expect_error_in(dir, "replay p.csv --volume ./clay.vdb --plastic -o s.h5 --sculpt-out clay",
                  "clay.vdb: --sculpt-out would overwrite the input volume ./clay.vdb");
  expect_error_in(dir, "replay p.csv --volume d.nhdr -o d.raw",
                  "d.raw: --output would overwrite the input volume data file d.raw");
  // Directories of frames (frame_NNNN.png) and of pictures.
  expect_error_in(dir,
                  "replay p.csv --volume block -o s.h5 --render-dir . --render-transfer "
                  "frame_0002.png",
                  ".: --render-dir would overwrite the input transfer function frame_0002.png (a "
                  "file it writes into .)");
  expect_error_in(dir, "render block -o " + dir + " --transfer frame_0002.png",
                  dir +
                      ": --output would overwrite the input transfer function frame_0002.png (a "
                      "file it writes into " +
                      dir + ")");
  expect_error_in(dir, "render clay.nrrd -o clay.nrrd",
                  "clay.nrrd: --output would overwrite the input volume clay.nrrd");
  // Nothing was written, and every input is byte for byte what it was.
  EXPECT_FALSE(fs::exists(dir + "/s.h5"));
  EXPECT_FALSE(fs::exists(dir + "/p.csv.partial"));
  EXPECT_FALSE(fs::exists(dir + "/clay.vdb.partial"));
  EXPECT_FALSE(fs::exists(dir + "/frame_0000.png"));
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    EXPECT_EQ(read_file(dir + "/" + inputs[i]), before[i]) << inputs[i];
  }
  EXPECT_TRUE(fs::is_symlink(dir + "/link.csv"));
  // An output beside its inputs is fine.
  const Result ok = run_in(dir, trace + "-o s.h5 -q");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
}

// `hapvox report SESSION -o DIR` writes force.png, lateness.png and relax.png into DIR.
TEST(CliOutputs, ReportRefusesAPictureNamedLikeItsSession) {
  const std::string dir = scratch_dir();
  const std::string session = dir + "/force.png";
  write_file(dir + "/t.csv", "t,x,y,z\n0,64,64,90\n0.01,64,64,89\n");
  ASSERT_EQ(run_in(dir, "replay t.csv --volume block -o s.h5").exit_code, 0);
  fs::rename(dir + "/s.h5", session);
  const std::string before = read_file(session);
  expect_error_in(dir, "report force.png -o .",
                  ".: --output would overwrite the input session force.png (a file it writes "
                  "into .)");
  expect_error_in(dir, "report force.png -o force.png",
                  "force.png: --output would overwrite the input session force.png");
  EXPECT_EQ(read_file(session), before);
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

// Issue 27: an output name over the file system's 255 bytes was "internal error: filesystem
// error", exit 1: std::filesystem threw from a check that did not ask for an error code.
TEST(CliErrors, AnOutputNameTooLongForTheFileSystemIsOneLine) {
  const std::string dir = scratch_dir();
  const std::string name = std::string(300, 'n');
  const std::string file_problem =
      "a file name of 304 bytes (312 as NAME.partial, while it is written)";
  const std::string folder_problem = "a folder name of 300 bytes";
  for (const auto& [output, problem] :
       {std::pair{name + ".csv", file_problem}, std::pair{name + "/t.csv", folder_problem}}) {
    const Result r = run_in(dir, "trace make press -o " + output);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err, "hapvox: error: " + std::string(120, 'n') + "...: " + problem +
                         ", longer than the file system allows (255)\n");
  }
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
