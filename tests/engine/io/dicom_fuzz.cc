// Fuzz target for the DICOM reader (engine/io/dicom.h, GDCM underneath): the first byte picks
// the layout, the rest is the data. Even: one .dcm file. Odd: a series folder of two files,
// the data split at the byte the second byte names (as a fraction of the length). Any bytes
// either read into a volume whose sizes match its samples or throw InputError whose message
// is one line naming the file or folder; nothing else may escape, crash, hang or allocate what
// a header claims.
//
// Built as a libFuzzer binary (dicom_fuzz) where the compiler has -fsanitize=fuzzer:
// `dicom_fuzz -max_total_time=60 CORPUS_DIR SEED_DIR` (scripts/fuzz.sh seeds it with pydicom's
// small test files). With HAPVOX_FUZZ_REPLAY (in io_tests, any compiler) a test feeds it
// seeded random mutations of pydicom's CT_small.dcm and MR_small.dcm, alone and as a series.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "engine/errors.h"
#include "engine/io/dicom.h"
#include "fuzz_check.h"

namespace {

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Reads `bytes` laid out as `layout` picks (see above) under `dir`: true when it reads, false
// on a one-line InputError naming what was read; aborts on anything else.
bool read_as_dicom(unsigned layout, unsigned split, const std::string& bytes,
                   const std::string& dir) {
  const std::string base = dir + "/dicom_fuzz_" + std::to_string(getpid());
  std::string path;
  if (layout % 2 == 0) {
    path = base + ".dcm";
    write_bytes(path, bytes);
  } else {
    path = base;
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
    const std::size_t at = bytes.size() * (split % 256) / 255;
    write_bytes(path + "/slice_1.dcm", bytes.substr(0, at));
    write_bytes(path + "/slice_2.dcm", bytes.substr(at));
  }
  bool read = false;
  try {
    const hapvox::engine::io::RawVolume raw = hapvox::engine::io::read_dicom(path);
    const auto samples = static_cast<std::size_t>(raw.dims.x()) *
                         static_cast<std::size_t>(raw.dims.y()) *
                         static_cast<std::size_t>(raw.dims.z());
    if (raw.intensity.size() != samples || !(raw.spacing_mm.minCoeff() > 0.0)) std::abort();
    read = true;
  } catch (const hapvox::InputError& e) {
    hapvox::testing::abort_unless_one_line_error(e, path);
  }
  std::filesystem::remove_all(path);
  return read;
}

// One input: layout byte, split byte, data.
int fuzz_dicom(const std::uint8_t* data, std::size_t size, bool* read = nullptr) {
  if (size < 2) return 0;
  const std::string bytes(reinterpret_cast<const char*>(data) + 2, size - 2);
  const bool ok =
      read_as_dicom(data[0], data[1], bytes, std::filesystem::temp_directory_path().string());
  if (read != nullptr) *read = ok;
  return 0;
}

}  // namespace

// io_tests holds volume_fuzz's entry point too; there the test calls fuzz_dicom.
#ifndef HAPVOX_FUZZ_REPLAY
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return fuzz_dicom(data, size);
}
#endif

#ifdef HAPVOX_FUZZ_REPLAY

#include <gtest/gtest.h>

#include <random>

#include "fuzz_mutate.h"
#include "test_data.h"

namespace {

const std::string kPydicomFiles = "/usr/lib/python3/dist-packages/pydicom/data/test_files/";

TEST(DicomFuzz, MutationsOfRealFilesReadOrGiveOneLineErrors) {
  const std::string dir = hapvox::testing::scratch_dir();
  const std::string ct = hapvox::testing::read_file(kPydicomFiles + "CT_small.dcm");
  const std::string mr = hapvox::testing::read_file(kPydicomFiles + "MR_small.dcm");
  // The unmutated files read, alone and as a two-slice folder of one file (GDCM reads the
  // second half as no DICOM, which the reader skips).
  ASSERT_TRUE(read_as_dicom(0, 0, ct, dir));
  ASSERT_TRUE(read_as_dicom(0, 0, mr, dir));
  ASSERT_TRUE(read_as_dicom(1, 255, ct, dir));
  std::mt19937_64 rng(20261203);
  int read = 0, rejected = 0;
  for (int i = 0; i < 500; ++i) {
    // Inputs as libFuzzer passes them: layout byte (one file or a two-file folder), split
    // byte, data.
    std::string input(2, '\0');
    input[0] = static_cast<char>(i % 4 < 2 ? 0 : 1);
    input[1] = static_cast<char>(rng() % 256);
    input += hapvox::testing::mutate(i % 2 == 0 ? ct : mr, rng);
    bool ok = false;
    fuzz_dicom(reinterpret_cast<const std::uint8_t*>(input.data()), input.size(), &ok);
    (ok ? read : rejected)++;
  }
  // Both outcomes happen: a test whose mutations all fail early would fuzz nothing.
  EXPECT_GT(read, 10);
  EXPECT_GT(rejected, 150);
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
