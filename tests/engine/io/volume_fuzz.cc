// Fuzz target for the volume readers (engine/io/formats.h): the first byte picks a format
// (NRRD, MetaImage, NIfTI, gzip NIfTI, raw), the rest is the file; for a raw file, its first
// line is the layout given after "FILE.raw:" (engine/io/raw_file.h) and the rest the file. Any
// bytes either read into a
// volume whose sizes match its samples or throw InputError whose message is one line
// naming the file; nothing else may escape, crash, hang or allocate what a header claims.
//
// Built as a libFuzzer binary (volume_fuzz) where the compiler has -fsanitize=fuzzer:
// `volume_fuzz -max_total_time=60 CORPUS_DIR`. With HAPVOX_FUZZ_REPLAY (in io_tests, any
// compiler) a test feeds it seeded random mutations of small files of every format.

#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "engine/errors.h"
#include "engine/io/formats.h"
#include "fuzz_check.h"

namespace {

constexpr std::array<const char*, 5> kExtensions = {".nrrd", ".mha", ".nii", ".nii.gz", ".raw"};

// Reads `bytes` as a file of the format `selector` picks: true when it reads, false on a
// one-line InputError naming the file; aborts on anything else.
bool read_as_volume(unsigned selector, const std::string& bytes, const std::string& dir) {
  const std::string extension = kExtensions[selector % kExtensions.size()];
  const std::string path = dir + "/fuzz_" + std::to_string(getpid()) + extension;
  std::string spec = path;
  std::string contents = bytes;
  if (extension == ".raw") {  // the layout's line, then the file
    const std::size_t newline = bytes.find('\n');
    spec = path + ":" + bytes.substr(0, newline);
    contents = newline == std::string::npos ? "" : bytes.substr(newline + 1);
  }
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  }
  try {
    const hapvox::engine::io::RawVolume raw = hapvox::engine::io::read_scalar_volume(spec);
    const auto samples = static_cast<std::size_t>(raw.dims.x()) *
                         static_cast<std::size_t>(raw.dims.y()) *
                         static_cast<std::size_t>(raw.dims.z());
    if (raw.intensity.size() != samples || !(raw.spacing_mm.minCoeff() > 0.0)) std::abort();
    std::filesystem::remove(path);
    return true;
  } catch (const hapvox::InputError& e) {
    hapvox::testing::abort_unless_one_line_error(e, path);
  }
  std::filesystem::remove(path);
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  read_as_volume(data[0], bytes, std::filesystem::temp_directory_path().string());
  return 0;
}

#ifdef HAPVOX_FUZZ_REPLAY

#include <gtest/gtest.h>

#include <random>

#include "engine/io/io_test_util.h"
#include "engine/io/metaimage.h"
#include "engine/io/nifti.h"
#include "engine/volume_io.h"
#include "fuzz_mutate.h"
#include "test_data.h"

namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

TEST(VolumeFuzz, MutationsOfEveryFormatReadOrGiveOneLineErrors) {
  const std::string dir = scratch_dir();
  // Seeds: hapvox's own writers (gzip NRRD, zlib MetaImage, NIfTI with and without gzip) and
  // uncompressed headers written by hand.
  const hapvox::engine::DensityField field = make_test_field();
  std::array<std::string, 4> seeds;
  const std::array<std::string, 4> names = {"/s.nrrd", "/s.mha", "/s.nii", "/s.nii.gz"};
  hapvox::engine::io::write_nrrd(field, dir + names[0]);
  hapvox::engine::io::write_metaimage(field, dir + names[1]);
  hapvox::engine::io::write_nifti(field, dir + names[2]);
  hapvox::engine::io::write_nifti(field, dir + names[3]);
  for (std::size_t i = 0; i < seeds.size(); ++i)
    seeds[i] = hapvox::testing::read_file(dir + names[i]);
  const std::string raw_nrrd = make_nrrd(basic_fields(), kEightBytes);
  const std::string raw_mha =
      "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementSpacing = 1 2 3\n"
      "TransformMatrix = 0 1 0 1 0 0 0 0 1\nOffset = 1 2 3\nElementType = MET_UCHAR\n"
      "ElementDataFile = LOCAL\n" +
      kEightBytes;
  // A raw file: its layout's line, then the samples.
  const std::string raw_file =
      "dims=2x2x2,type=int8,endian=big,spacing_mm=1x2x3,origin_mm=-1x0x5\n" + kEightBytes;
  std::mt19937_64 rng(20261203);
  int read = 0, rejected = 0;
  for (int i = 0; i < 7500; ++i) {
    // Formats in turn; every other NRRD and MetaImage input from the uncompressed seeds.
    const unsigned format = static_cast<unsigned>(i % 5);
    const bool plain = format < 2 && (i / 5) % 2 == 1;
    const std::string& seed = format == 4 ? raw_file
                              : plain     ? (format == 0 ? raw_nrrd : raw_mha)
                                          : seeds[format];
    (read_as_volume(format, hapvox::testing::mutate(seed, rng), dir) ? read : rejected)++;
  }
  // Both outcomes happen: a test whose mutations all fail early would fuzz nothing.
  EXPECT_GT(read, 100);
  EXPECT_GT(rejected, 1000);
}

// Found by volume_fuzz in CI: a raw file's layout line ending in ".vdb" made the spec a
// .vdb path with a name longer than the system allows, whose check threw filesystem_error
// (a crash) instead of "cannot open file".
TEST(VolumeFuzz, ASpecWithANameTooLongForTheSystemIsOneLineNotACrash) {
  const std::string dir = scratch_dir();
  EXPECT_FALSE(read_as_volume(4, std::string(300, 'x') + ".vdb\n" + kEightBytes, dir));
  const std::string spec = dir + "/" + std::string(300, 'x') + ".vdb";
  EXPECT_EQ(hapvox::testing::input_error_of([&] { hapvox::engine::io::read_scalar_volume(spec); }),
            spec + ": cannot open file");
}

}  // namespace

#endif  // HAPVOX_FUZZ_REPLAY
