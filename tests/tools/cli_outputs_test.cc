// Issue 27 end to end: outputs that cannot clobber (engine/io/output_file.h through every
// command), one command's outputs checked against each other, realtime runs that finish
// their session on SIGINT and SIGTERM, and a killed run's session recovered.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "haptics/session.h"
#include "loopback_port.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::read_file;
using testing::run_hapvox;
using testing::scratch_dir;
using Result = testing::CommandResult;

void expect_error(const std::string& args, const std::string& line) {
  const Result r = run_hapvox(args);
  EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.out << r.err;
  EXPECT_EQ(r.err, "hapvox: error: " + line + "\n") << args;
}

// A press-and-hold trace of `seconds` on the block generator's face.
std::string write_press(const std::string& dir, double seconds) {
  const std::string path = dir + "/press.csv";
  std::ofstream out(path);
  out << "t,x,y,z\n";
  for (int k = 0; k <= static_cast<int>(seconds * 100); ++k) {
    out << k / 100.0 << ",64,64," << (k < 50 ? 96.0 - 0.02 * k : 95.0) << "\n";
  }
  return path;
}

// Starts `hapvox ARGS` in the background; returns its pid.
pid_t start_hapvox(const std::string& dir, const std::string& args) {
  const std::string command = testing::hapvox_binary() + " " + args + " > " + dir +
                              "/bg_out.txt 2> " + dir + "/bg_err.txt & echo $! > " + dir +
                              "/bg_pid";
  EXPECT_EQ(std::system(("sh -c '" + command + "'").c_str()), 0);
  return static_cast<pid_t>(std::stol(read_file(dir + "/bg_pid")));
}

bool wait_for(const std::function<bool()>& done, double seconds) {
  for (int i = 0; i < static_cast<int>(seconds * 100); ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

// Waits for `pid` (not our child: the shell's) to end.
bool wait_gone(pid_t pid, double seconds) {
  return wait_for([&] { return ::kill(pid, 0) != 0; }, seconds);
}

// `python3 -c` on a session: h5py must open it, as users do.
std::string h5py_rows(const std::string& session) {
  const std::string out = session + ".rows.txt";
  const std::string command = "/usr/bin/python3 -c \"import h5py; f = h5py.File('" + session +
                              "', 'r'); print(f['time_s'].shape[0], f['force_n'].shape[0], "
                              "int(f.attrs['complete']))\" > " +
                              out + " 2>&1";
  std::system(command.c_str());
  return read_file(out);
}

TEST(CliOutputs, ADeviceNodeAFifoAndAPlantedLinkAreLeftAsTheyWere) {
  const std::string dir = scratch_dir();
  const std::string trace = write_press(dir, 0.5);
  const std::string replay = "replay " + trace + " --volume block -q -o ";
  const std::string special =
      ": is not a regular file (a device, FIFO or socket): outputs are written to regular files "
      "only";
  ASSERT_EQ(::mkfifo((dir + "/fifo.h5").c_str(), 0644), 0);
  expect_error(replay + dir + "/fifo.h5", dir + "/fifo.h5" + special);
  EXPECT_TRUE(fs::is_fifo(dir + "/fifo.h5"));
  if (::geteuid() == 0) {  // only root makes device nodes; CI runs as root
    ASSERT_EQ(::mknod((dir + "/null").c_str(), S_IFCHR | 0666, makedev(1, 3)), 0);
    expect_error(replay + dir + "/null", dir + "/null" + special);
    EXPECT_TRUE(fs::is_character_file(dir + "/null"));
  }
  std::ofstream(dir + "/victim.txt") << "precious";
  fs::create_symlink("victim.txt", dir + "/planted.h5.partial");
  const std::string planted = dir + "/planted.h5";
  const std::string refused =
      planted + ": " + planted +
      ".partial is a symbolic link: refusing to write through it (remove it)";
  expect_error(replay + planted, refused);
  fs::create_symlink("victim.txt", dir + "/planted.nrrd.partial");
  expect_error(
      "convert block:dims=8 " + dir + "/planted.nrrd",
      dir + "/planted.nrrd: " + dir +
          "/planted.nrrd.partial is a symbolic link: refusing to write through it (remove it)");
  EXPECT_EQ(read_file(dir + "/victim.txt"), "precious");
  EXPECT_FALSE(fs::exists(planted));
  EXPECT_FALSE(fs::exists(dir + "/planted.nrrd"));
  // A link at the output itself is not replaced either.
  fs::create_symlink("victim.txt", dir + "/link.h5");
  expect_error(replay + dir + "/link.h5",
               dir +
                   "/link.h5: is a symbolic link: outputs are never written through links "
                   "(remove it, or name the file it points to)");
  EXPECT_TRUE(fs::is_symlink(dir + "/link.h5"));
  // report's pictures, which matplotlib writes, go through the output module too.
  ASSERT_EQ(run_hapvox(replay + dir + "/s.h5").exit_code, 0);
  fs::create_directories(dir + "/plots");
  fs::create_symlink("../victim.txt", dir + "/plots/force.png");
  expect_error("report " + dir + "/s.h5 -o " + dir + "/plots",
               dir +
                   "/plots/force.png: is a symbolic link: outputs are never written through "
                   "links (remove it, or name the file it points to)");
  EXPECT_TRUE(fs::is_symlink(dir + "/plots/force.png"));
  EXPECT_EQ(read_file(dir + "/victim.txt"), "precious");
}

TEST(CliOutputs, ASecondRunOnOneOutputIsRefusedAndTheFirstSessionStaysValid) {
  const std::string dir = scratch_dir();
  const std::string trace = write_press(dir, 3.0);
  const std::string session = dir + "/s.h5";
  const pid_t first =
      start_hapvox(dir, "replay " + trace + " --volume block --realtime -q -o " + session);
  ASSERT_TRUE(wait_for([&] { return fs::exists(session + ".partial"); }, 20.0));
  const Result second = run_hapvox("replay " + trace + " --volume block -q -o " + session);
  EXPECT_EQ(second.exit_code, 2) << second.err;
  EXPECT_EQ(second.err, "hapvox: error: " + session + ": another run is writing it (" + session +
                            ".partial is locked)\n");
  ASSERT_TRUE(wait_gone(first, 30.0));
  EXPECT_EQ(read_file(dir + "/bg_err.txt"), "");
  const haptics::SessionInfo info = haptics::read_session_info(session);
  EXPECT_TRUE(info.complete);
  EXPECT_EQ(info.rows, 3001u);
  EXPECT_EQ(h5py_rows(session), "3001 3001 1\n");
}

TEST(CliOutputs, OneCommandsOutputsMayNotNameOneFile) {
  const std::string dir = scratch_dir();
  const std::string trace = write_press(dir, 0.5);
  const std::uint16_t port = testing::free_port();
  const std::string device =
      "replay --volume block --realtime --device udp:127.0.0.1:" + std::to_string(port);
  expect_error(device + " -o " + dir + "/s.h5 --trace-out " + dir + "/s.h5",
               dir + "/s.h5: --trace-out and --output name the same file");
  expect_error("replay " + trace + " --volume block --plastic -o " + dir +
                   "/xs.nrrd --sculpt-out " + dir + "/xs",
               dir + "/xs.nrrd: --sculpt-out and --output name the same file");
  EXPECT_TRUE(fs::is_empty(dir + "/") || !fs::exists(dir + "/s.h5"));
  EXPECT_FALSE(fs::exists(dir + "/xs.nrrd"));
}

TEST(CliOutputs, ALiveRunThatGotNoPositionSaysSoAndWritesNothing) {
  const std::string dir = scratch_dir();
  const std::uint16_t port = testing::free_port();
  const Result r = run_hapvox(
      "replay --volume block -q --realtime --device udp:127.0.0.1:" + std::to_string(port) +
      " --end-after-silence-s 0.3 -o " + dir + "/s.h5");
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "hapvox: error: udp:127.0.0.1:" + std::to_string(port) +
                       ": no position arrived before the run ended: no tick ran, nothing written "
                       "to " +
                       dir + "/s.h5\n");
  EXPECT_EQ(r.out.find("-> "), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir + "/s.h5"));
  EXPECT_FALSE(fs::exists(dir + "/s.h5.partial"));
}

// Realtime trace replays ignored Ctrl-C and SIGTERM and left an unfinished .partial.
TEST(CliSignals, SigintAndSigtermFinishARealtimeTraceReplaysSession) {
  for (const int signal : {SIGINT, SIGTERM}) {
    const std::string dir = scratch_dir();
    const std::string trace = write_press(dir, 30.0);
    const std::string session = dir + "/s.h5";
    const pid_t pid =
        start_hapvox(dir, "replay " + trace + " --volume block --realtime -o " + session);
    ASSERT_TRUE(wait_for([&] { return fs::exists(session + ".partial"); }, 20.0));
    const auto sent = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));
    ASSERT_EQ(::kill(pid, signal), 0);
    ASSERT_TRUE(wait_gone(pid, 20.0)) << signal;
    const double ran_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
    const haptics::SessionInfo info = haptics::read_session_info(session);
    EXPECT_TRUE(info.complete) << signal;
    // Every tick up to the signal: at least the 2.5 s since the file appeared, less 1 s.
    EXPECT_GE(info.rows, 1500u) << signal;
    EXPECT_LE(info.rows, static_cast<std::size_t>((ran_s + 1.0) * 1000.0)) << signal;
    EXPECT_FALSE(fs::exists(session + ".partial"));
    const std::string h5py = h5py_rows(session);
    EXPECT_EQ(h5py, std::to_string(info.rows) + " " + std::to_string(info.rows) + " 1\n");
    EXPECT_NE(read_file(dir + "/bg_out.txt").find("stopped          by Ctrl-C or SIGTERM after"),
              std::string::npos);
  }
}

TEST(CliSignals, AKilledRunsSessionIsReadAndRecovered) {
  const std::string dir = scratch_dir();
  const std::string trace = write_press(dir, 30.0);
  const std::string session = dir + "/s.h5";
  const std::string partial = session + ".partial";
  const pid_t pid =
      start_hapvox(dir, "replay " + trace + " --volume block --realtime -q -o " + session);
  ASSERT_TRUE(wait_for([&] { return fs::exists(partial); }, 20.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ASSERT_TRUE(wait_gone(pid, 20.0));
  ASSERT_TRUE(fs::exists(partial));
  EXPECT_FALSE(fs::exists(session));
  const std::string before = read_file(partial);

  const Result info = run_hapvox("info " + partial);
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("INCOMPLETE (the run did not finish)"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("recover it       hapvox recover " + partial), std::string::npos);

  // A rerun to the same output keeps the killed run's rows.
  expect_error("replay " + trace + " --volume block -q -o " + session,
               session + ": " + partial +
                   " is left from a run that did not finish: recover it (hapvox recover " +
                   partial + ", for a session) or remove it");

  const Result report = run_hapvox("report " + partial + " -o " + dir + "/plots");
  EXPECT_EQ(report.exit_code, 0) << report.out << report.err;
  EXPECT_TRUE(fs::exists(dir + "/plots/force.png"));

  const Result recovered = run_hapvox("recover " + partial);
  ASSERT_EQ(recovered.exit_code, 0) << recovered.err;
  const haptics::SessionInfo whole = haptics::read_session_info(session);
  EXPECT_TRUE(whole.complete);
  // Flushed every 1000 ticks: the rows up to at most ~1 s before the kill, 3 s in.
  EXPECT_GE(whole.rows, 1000u);
  EXPECT_EQ(whole.rows % 1000, 0u);
  EXPECT_EQ(h5py_rows(session),
            std::to_string(whole.rows) + " " + std::to_string(whole.rows) + " 1\n");
  EXPECT_NE(recovered.out.find("recovered " + partial + " -> " + session + ": " +
                               std::to_string(whole.rows) + " rows"),
            std::string::npos)
      << recovered.out;
  EXPECT_EQ(read_file(partial), before);  // the input is left as it was
  // Never over an existing file.
  expect_error("recover " + partial,
               session + ": exists: recover into another name (-o), nothing is replaced");
}

}  // namespace
}  // namespace hapvox
