// Reading in a child process (engine/io/child_read.h): what the child reads or throws comes
// back whole; a child that dies is one InputError naming the file.

#include "engine/io/child_read.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <stdexcept>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

io::RawVolume turned_volume(const std::string&) {
  io::RawVolume raw;
  raw.dims = Vec3i(3, 2, 1);
  raw.intensity = {-1.5f, 0.0f, 2.25f, 1e30f, -7.0f, 8.0f};
  raw.spacing_mm = Vec3d(0.5, 2.0, 3.0);
  raw.origin_mm = Vec3d(-1.0, 2.5, 1e-9);
  raw.direction << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  raw.holds_density = true;
  raw.sample_type = "float";
  raw.min_intensity = -7.0;
  raw.max_intensity = 1e30;
  return raw;
}

io::RawVolume throws_input_error(const std::string&) {
  throw InputError("series/slice_7.dcm", "two slices at one position");
}

io::RawVolume throws_other(const std::string&) { throw std::runtime_error("bad\nthings"); }

io::RawVolume aborts(const std::string&) { std::abort(); }

// _exit: std::exit would flush the parent's copied output buffers a second time.
io::RawVolume exits(const std::string&) { ::_exit(3); }

io::RawVolume allocates_4_gib(const std::string&) {
  io::RawVolume raw;
  raw.intensity.resize(std::size_t{1} << 30);  // 4 GiB of floats
  return raw;
}

TEST(ChildRead, TheVolumeComesBackBitForBit) {
  const io::RawVolume expected = turned_volume("");
  const io::RawVolume raw = io::read_in_child_process("v", turned_volume, "Lib", 1 << 30);
  EXPECT_EQ(raw.dims, expected.dims);
  EXPECT_EQ(raw.intensity, expected.intensity);
  EXPECT_EQ(raw.spacing_mm, expected.spacing_mm);
  EXPECT_EQ(raw.origin_mm, expected.origin_mm);
  EXPECT_EQ(raw.direction, expected.direction);
  EXPECT_TRUE(raw.holds_density);
  EXPECT_EQ(raw.sample_type, "float");
  EXPECT_EQ(raw.min_intensity, -7.0);
  EXPECT_EQ(raw.max_intensity, 1e30);
}

TEST(ChildRead, ErrorsAndCrashesAreOneLineInputErrors) {
  // The child's InputError keeps its own source (a slice, not the folder read).
  EXPECT_EQ(testing::input_error_of(
                [] { io::read_in_child_process("series", throws_input_error, "Lib", 1 << 30); }),
            "series/slice_7.dcm: two slices at one position");
  EXPECT_EQ(testing::input_error_of(
                [] { io::read_in_child_process("v.dcm", throws_other, "Lib", 1 << 30); }),
            "v.dcm: Lib failed reading it: bad\\x0Athings");
  EXPECT_EQ(
      testing::input_error_of([] { io::read_in_child_process("v.dcm", aborts, "Lib", 1 << 30); }),
      "v.dcm: Lib crashed reading it (signal 6, Aborted): a corrupt or truncated file");
  EXPECT_EQ(
      testing::input_error_of([] { io::read_in_child_process("v.dcm", exits, "Lib", 1 << 30); }),
      "v.dcm: Lib crashed reading it (it exited with status 3): a corrupt or truncated "
      "file");
}

// A corrupt header's claim stops at the budget, in the child.
TEST(ChildRead, AllocationsPastTheBudgetAreRefused) {
  const std::string error = testing::input_error_of(
      [] { io::read_in_child_process("v.dcm", allocates_4_gib, "Lib", 256 << 20); });
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  // A sanitizer's allocator aborts instead of throwing std::bad_alloc.
  EXPECT_EQ(error.rfind("v.dcm: Lib crashed reading it (", 0), 0u) << error;
#else
  EXPECT_EQ(error, "v.dcm: Lib needed more than 256 MB reading it: a corrupt file");
#endif
}

}  // namespace
}  // namespace hapvox::engine
