// Issue 27: outputs that cannot harm files (engine/io/output_file.h).

#include "engine/io/output_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::engine::io {
namespace {

namespace fs = std::filesystem;
using testing::input_error_of;
using testing::read_file;
using testing::scratch_dir;

TEST(OutputFile, WritesThroughAPartialAndRenamesOnlyOnCommit) {
  const std::string dir = scratch_dir();
  std::ofstream(dir + "/out.txt") << "old";
  {
    OutputFile out(dir + "/out.txt");
    out.write("new", 3);
    EXPECT_EQ(read_file(dir + "/out.txt"), "old");  // replaced only on success
    EXPECT_EQ(read_file(dir + "/out.txt.partial"), "new");
    out.commit();
  }
  EXPECT_EQ(read_file(dir + "/out.txt"), "new");
  EXPECT_FALSE(fs::exists(dir + "/out.txt.partial"));
}

// `ln -s victim.txt planted.h5.partial; hapvox replay ... -o planted.h5` overwrote victim.txt.
TEST(OutputFile, APlantedPartialLinkIsRefusedAndItsTargetKept) {
  const std::string dir = scratch_dir();
  std::ofstream(dir + "/victim.txt") << "precious";
  fs::create_symlink("victim.txt", dir + "/planted.h5.partial");
  const std::string out = dir + "/planted.h5";
  EXPECT_EQ(
      input_error_of([&] { OutputFile file(out); }),
      out + ": " + out + ".partial is a symbolic link: refusing to write through it (remove it)");
  EXPECT_EQ(
      input_error_of([&] { write_text_atomically(out, "x"); }),
      out + ": " + out + ".partial is a symbolic link: refusing to write through it (remove it)");
  // A dangling one too.
  fs::create_symlink("nowhere", dir + "/dangling.h5.partial");
  EXPECT_NE(input_error_of([&] { OutputFile file(dir + "/dangling.h5"); }), "");
  EXPECT_FALSE(fs::exists(dir + "/nowhere"));
  EXPECT_EQ(read_file(dir + "/victim.txt"), "precious");
  EXPECT_FALSE(fs::exists(out));
}

TEST(OutputFile, ALinkADirectoryOrASpecialFileAtTheOutputIsRefused) {
  const std::string dir = scratch_dir();
  std::ofstream(dir + "/victim.txt") << "precious";
  fs::create_symlink("victim.txt", dir + "/link.h5");
  EXPECT_EQ(input_error_of([&] { check_output_target(dir + "/link.h5"); }),
            dir +
                "/link.h5: is a symbolic link: outputs are never written through links (remove "
                "it, or name the file it points to)");
  fs::create_directory(dir + "/folder");
  EXPECT_EQ(input_error_of([&] { check_output_target(dir + "/folder"); }),
            dir + "/folder: is a directory, expected a file name");
  ASSERT_EQ(::mkfifo((dir + "/fifo").c_str(), 0644), 0);
  const std::string special =
      ": is not a regular file (a device, FIFO or socket): outputs are written to regular files "
      "only";
  EXPECT_EQ(input_error_of([&] { write_text_atomically(dir + "/fifo", "x"); }),
            dir + "/fifo" + special);
  EXPECT_TRUE(fs::is_fifo(dir + "/fifo"));
  // A device node (as /dev/null is): only root can make one; CI runs as root.
  if (::geteuid() == 0) {
    ASSERT_EQ(::mknod((dir + "/null").c_str(), S_IFCHR | 0666, makedev(1, 3)), 0);
    EXPECT_EQ(input_error_of([&] { write_text_atomically(dir + "/null", "x"); }),
              dir + "/null" + special);
    EXPECT_TRUE(fs::is_character_file(dir + "/null"));
  }
  EXPECT_EQ(read_file(dir + "/victim.txt"), "precious");
  EXPECT_TRUE(fs::is_symlink(dir + "/link.h5"));
}

// Two replays to one -o: the second truncated the first's .partial, which then ended
// "complete" and corrupt.
TEST(OutputFile, ASecondWriterIsRefusedWhileTheFirstHoldsItsPartial) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/s.h5";
  OutputFile first(path);
  first.write("first run's rows", 16);
  EXPECT_EQ(input_error_of([&] { OutputFile second(path); }),
            path + ": another run is writing it (" + path + ".partial is locked)");
  EXPECT_EQ(input_error_of([&] { check_output_target(path); }),
            path + ": another run is writing it (" + path + ".partial is locked)");
  EXPECT_EQ(read_file(path + ".partial"), "first run's rows");
  first.commit();
  EXPECT_EQ(read_file(path), "first run's rows");
}

TEST(OutputFile, AKilledRunsPartialIsNeverOverwritten) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/s.h5";
  std::ofstream(path + ".partial") << "rows of a killed run";
  EXPECT_EQ(input_error_of([&] { OutputFile out(path); }),
            path + ": " + path +
                ".partial is left from a run that did not finish: recover it (hapvox recover " +
                path + ".partial, for a session) or remove it");
  EXPECT_EQ(read_file(path + ".partial"), "rows of a killed run");
}

TEST(OutputFile, DiscardRemovesOnlyItsOwnPartial) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/s.txt";
  {
    OutputFile out(path);
    out.write("x", 1);
    out.discard();
  }
  EXPECT_FALSE(fs::exists(path + ".partial"));
  {
    // Not committed, not discarded: kept for a post-mortem.
    OutputFile out(path);
    out.write("y", 1);
  }
  EXPECT_EQ(read_file(path + ".partial"), "y");
  fs::remove(path + ".partial");
  OutputFile out(path);
  // Someone replaced the partial while a library wrote it by name: not moved into place.
  fs::remove(path + ".partial");
  std::ofstream(path + ".partial") << "theirs";
  EXPECT_EQ(input_error_of([&] { out.commit(); }),
            path + ": " + path + ".partial was replaced while it was written");
  out.discard();
  EXPECT_EQ(read_file(path + ".partial"), "theirs");
  EXPECT_FALSE(fs::exists(path));
}

TEST(OutputFile, ANameTooLongIsOneLine) {
  const std::string dir = scratch_dir();
  const std::string path = dir + "/" + std::string(250, 'n') + ".h5";
  // The command line's check (tools/cli.cc's check_output_path) and the writer's are one.
  EXPECT_EQ(input_error_of([&] { check_output_target(path); }),
            printable(path, 120) +
                ": a file name of 253 bytes (261 as NAME.partial, while it is written), longer "
                "than the file system allows (255)");
  EXPECT_EQ(input_error_of([&] { check_output_target(dir + "/missing/s.h5"); }),
            dir + "/missing/s.h5: output directory " + dir + "/missing does not exist");
}

}  // namespace
}  // namespace hapvox::engine::io
