// Input bombs end to end (tools/input_limits.cc, docs/formats.md "Limits"): small files that
// declare gigabytes, each generated here, get one line naming the file, the limit and the
// flag that raises it, exit 2, in bounded memory and time, measured by /usr/bin/time (GNU
// time, scripts/setup.sh). Each of them grew past 8 GB, crashed or ended in an internal
// error before its check.

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "haptics/h5_declared_rows.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::scratch_dir;
using testing::source_path;

// The bounds, for the program users run. Under AddressSanitizer (CI's first stage;
// the tests are built as the command is) every allocation carries redzones and freed memory
// sits in a quarantine, so the bounds are four times wider there: still far below the
// gigabytes a reader that allocates before it checks reaches.
#if defined(__SANITIZE_ADDRESS__)
constexpr double kSanitizerFactor = 4.0;
#else
constexpr double kSanitizerFactor = 1.0;
#endif
constexpr double kMaxRssMb = 256.0 * kSanitizerFactor;
constexpr double kMaxSeconds = 5.0 * kSanitizerFactor;

struct Measured {
  testing::CommandResult result;
  double max_rss_mb = -1.0;
  double elapsed_s = -1.0;
};

// `hapvox ARGS` under GNU time, its report in a file beside the test's scratch folder.
Measured run_measured(const std::string& dir, const std::string& args) {
  const std::string report = dir + ".time.txt";
  Measured m;
  m.result = testing::run_hapvox_env("/usr/bin/time -v -o '" + report + "'", args);
  std::ifstream in(report);
  for (std::string line; std::getline(in, line);) {
    const auto value = line.substr(line.rfind(": ") + 2);
    if (line.find("Maximum resident set size (kbytes)") != std::string::npos) {
      m.max_rss_mb = std::stod(value) / 1024.0;
    } else if (line.find("Elapsed (wall clock) time") != std::string::npos) {
      double minutes = 0.0, seconds = 0.0;  // m:ss.ss (under an hour)
      if (std::sscanf(value.c_str(), "%lf:%lf", &minutes, &seconds) == 2) {
        m.elapsed_s = 60.0 * minutes + seconds;
      }
    }
  }
  return m;
}

// The contract for a bomb: exit 2, one line on stderr naming `file` and saying `problem`,
// in at most 256 MB and 5 s.
void expect_refused(const std::string& dir, const std::string& args, const std::string& file,
                    const std::string& problem) {
  const Measured m = run_measured(dir, args);
  EXPECT_EQ(m.result.exit_code, 2) << args << "\n" << m.result.err;
  EXPECT_EQ(m.result.err.find("hapvox: error: " + file), 0u) << m.result.err;
  EXPECT_NE(m.result.err.find(problem), std::string::npos) << m.result.err;
  EXPECT_EQ(m.result.err.find('\n'), m.result.err.size() - 1) << m.result.err;
  EXPECT_GT(m.max_rss_mb, 0.0);
  EXPECT_LE(m.max_rss_mb, kMaxRssMb) << args;
  EXPECT_GE(m.elapsed_s, 0.0);
  EXPECT_LE(m.elapsed_s, kMaxSeconds) << args;
  std::printf("bomb %s: %.1f MB, %.2f s\n", file.c_str(), m.max_rss_mb, m.elapsed_s);
}

using testing::write_file;

// A NIfTI-1 header (nifti1.h's offsets) of `n`^3 float32 samples, then gzip'd zeros: 300 MB
// of them, so a reader that inflates before it checks grows past the 256 MB.
void write_nifti_bomb(const std::string& path, std::int16_t n) {
  std::string header(352, '\0');
  const std::int32_t size = 348;
  const std::int16_t dim[8] = {3, n, n, n, 1, 1, 1, 1};
  const std::int16_t datatype = 16, bitpix = 32;  // DT_FLOAT32
  const float pixdim[8] = {1, 1, 1, 1, 1, 1, 1, 1};
  const float vox_offset = 352.0f;
  std::memcpy(&header[0], &size, 4);
  std::memcpy(&header[40], dim, 16);
  std::memcpy(&header[70], &datatype, 2);
  std::memcpy(&header[72], &bitpix, 2);
  std::memcpy(&header[76], pixdim, 32);
  std::memcpy(&header[108], &vox_offset, 4);
  std::memcpy(&header[344], "n+1", 4);
  gzFile out = gzopen(path.c_str(), "wb1");
  ASSERT_NE(out, nullptr);
  gzwrite(out, header.data(), static_cast<unsigned>(header.size()));
  const std::vector<char> zeros(1 << 20, '\0');
  for (int mb = 0; mb < 300; ++mb) gzwrite(out, zeros.data(), static_cast<unsigned>(zeros.size()));
  gzclose(out);
}

TEST(InputLimits, AGzipVolumeDeclaringGigabytesIsRefusedFromItsHeader) {
  const std::string dir = scratch_dir();
  const std::string bomb = dir + "/bomb.nii.gz";
  write_nifti_bomb(bomb, 1250);  // 7.8 GB decoded
  expect_refused(dir, "info " + bomb, bomb,
                 "1250 x 1250 x 1250 float samples take 7451 MB decoded, over the limit of "
                 "2048 MB (raise it with --max-input-mb)");
  // Raised, the limit lets the same file reach its payload, short of what its header says.
  const testing::CommandResult raised =
      testing::run_hapvox("info " + bomb + " --max-input-mb 8000");
  EXPECT_EQ(raised.exit_code, 2);
  EXPECT_NE(raised.err.find(bomb + ": truncated data"), std::string::npos) << raised.err;
}

TEST(InputLimits, HdfTracesDeclaringBillionsOfRowsAreRefusedFromTheirDataspace) {
  const std::string dir = scratch_dir();
  for (const auto& [name, rows] :
       {std::pair<std::string, hsize_t>{"many.h5", 1'500'000'000},
        std::pair<std::string, hsize_t>{"absurd.h5", hsize_t{1} << 40}}) {
    const std::string trace = dir + "/" + name;
    ASSERT_TRUE(testing::write_h5_declaring_rows(trace, rows));
    expect_refused(dir, "replay " + trace + " --volume block -q -o " + dir + "/s.h5", trace,
                   "dataset 't' declares " + std::to_string(rows) +
                       " rows, over the limit of 50000000 rows (raise it with --max-trace-rows)");
  }
}

TEST(InputLimits, ACsvTraceWhoseTimeJumpsIsRefusedBeforeResampling) {
  const std::string dir = scratch_dir();
  const std::string trace = dir + "/jump.csv";
  write_file(trace, "t,x,y,z\n0,0,0,40\n900000,0,0,40\n");
  expect_refused(dir, "replay " + trace + " --volume block -q -o " + dir + "/s.h5", trace,
                 "its time span of 9e+05 s at 1000 Hz makes 900000001 rows, over the limit of "
                 "50000000 rows (raise it with --max-trace-rows)");
  // Lowered, the limit refuses a 2 s trace; the default replays it.
  write_file(trace, "t,x,y,z\n0,0,0,40\n2,0,0,40\n");
  expect_refused(dir,
                 "replay " + trace + " --volume block --max-trace-rows 1000 -q -o " + dir + "/s.h5",
                 trace, "makes 2001 rows, over the limit of 1000 rows");
  EXPECT_EQ(
      testing::run_hapvox("replay " + trace + " --volume block -q -o " + dir + "/s.h5").exit_code,
      0);
}

TEST(InputLimits, ASweepOfABillionRowsIsRefusedBeforeItsRowsAreMade) {
  const std::string dir = scratch_dir();
  std::string list;
  for (int i = 0; i < 1000; ++i) list += (i ? ", " : "") + std::to_string(i + 1);
  const std::string manifest = dir + "/billion.toml";
  write_file(manifest,
             "traces = ['a.csv']\nvolumes = ['block']\n[options]\n"
             "tool-diameter-mm = [" +
                 list + "]\nyoungs-modulus-pa = [" + list + "]\npoisson = [" + list + "]\n");
  expect_refused(dir, "sweep " + manifest + " -o " + dir + "/out --dry-run", manifest + ":1",
                 "describes 1000000000 replays, over the limit of 100000 rows (raise it with "
                 "--max-sweep-rows)");
}

TEST(InputLimits, TomlNestedPastItsDepthIsRefusedBeforeTomlReadsIt) {
  const std::string dir = scratch_dir();
  std::string dotted = "[a";
  for (int i = 0; i < 30000; ++i) dotted += ".a";  // 60 kB: a SIGSEGV in toml++
  const std::string materials = dir + "/deep.toml";
  write_file(materials, dotted + "]\n");
  expect_refused(dir,
                 "replay " + source_path("traces/engine_press.csv") +
                     " --volume block --materials " + materials + " -q -o " + dir + "/s.h5",
                 materials + ":1", "nests 30002 levels deep");
  std::string key = "a";
  for (int i = 0; i < 100000; ++i) key += ".a";
  const std::string manifest = dir + "/deep_sweep.toml";
  write_file(manifest, "traces = ['a.csv']\n" + key + " = 1\n");
  expect_refused(dir, "sweep " + manifest + " -o " + dir + "/out --dry-run", manifest + ":2",
                 "nests 100001 levels deep");
}

}  // namespace
}  // namespace hapvox
