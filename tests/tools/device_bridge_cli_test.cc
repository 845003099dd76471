// hapvox replay --device udp:HOST:PORT with hapvox device-sim, as two processes on loopback:
// the forces the device-sim gets back are those of a direct replay of its trace; with
// --device-key only the key's device drives the tool, with --device-peer only the named
// sender; bad flags are one line each.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "engine/errors.h"
#include "haptics/session.h"
#include "haptics/udp_socket.h"
#include "loopback_port.h"
#include "session_compare.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;
using testing::scratch_dir;

using testing::free_port;
using testing::listening;

struct Answer {
  bool answered = false;
  double force[3] = {0, 0, 0};
  unsigned status = 0;
  unsigned long long tick = 0;
};

std::vector<Answer> read_answers(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "sequence,answered,fx,fy,fz,status,tick,round_trip_ns");
  std::vector<Answer> answers;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string field;
    std::vector<std::string> v;
    while (std::getline(fields, field, ',')) v.push_back(field);
    Answer a;
    a.answered = v.at(1) == "1";
    for (int i = 0; i < 3; ++i) a.force[i] = std::strtod(v.at(2 + i).c_str(), nullptr);
    a.status = static_cast<unsigned>(std::stoul(v.at(5)));
    a.tick = std::stoull(v.at(6));
    answers.push_back(a);
  }
  return answers;
}

// Compared by sequence number: each position sent at full force (past the 100-tick ramp-in,
// no ramp under way: status bit 0 clear) was answered with the force a direct replay
// computed for that sample, to the last bit (through the CSV's 17 digits). Returns how many
// answers were compared.
std::size_t expect_direct_forces(const std::string& forces_csv, const std::string& direct_h5) {
  const std::vector<double> direct = haptics::read_session_column(direct_h5, "/force_n");
  const std::vector<Answer> answers = read_answers(forces_csv);
  EXPECT_EQ(answers.size(), direct.size() / 3 + 1);  // and the end packet's
  std::size_t compared = 0;
  for (std::size_t k = 100; k + 1 < answers.size() && 3 * k + 2 < direct.size(); ++k) {
    if (!answers[k].answered || (answers[k].status & 1u) != 0) continue;
    ++compared;
    for (int a = 0; a < 3; ++a) {
      if (answers[k].force[a] != direct[3 * k + a]) {
        ADD_FAILURE() << "sequence " << k << ": " << answers[k].force[a] << " against "
                      << direct[3 * k + a];
        return compared;
      }
    }
  }
  return compared;
}

// The stylus turns 2 mrad a sample about (0.6, 0, 0.8): quaternion columns added to a trace.
const std::string kTurn = " --orientation-cols qw,qx,qy,qz";
void add_turning_stylus(const std::string& path) {
  std::ifstream in(path);
  std::string line, out;
  std::getline(in, line);
  out = line + ",qw,qx,qy,qz\n";
  for (int k = 0; std::getline(in, line); ++k) {
    const double half = 0.001 * k;
    char q[128];
    std::snprintf(q, sizeof q, ",%.17g,%.17g,0,%.17g\n", std::cos(half), 0.6 * std::sin(half),
                  0.8 * std::sin(half));
    out += line + q;
  }
  in.close();
  std::ofstream(path) << out;
}

// `hapvox ARGS` (a live session: it waits for its device) on a thread of its own, running
// once it listens on `port`.
class LiveSession {
 public:
  LiveSession(std::uint16_t port, const std::string& args)
      : thread_([this, args] { result_ = run_hapvox(args); }) {
    for (int i = 0; i < 1000 && !listening(port); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  testing::CommandResult finish() {
    thread_.join();
    return result_;
  }

 private:
  testing::CommandResult result_;
  std::thread thread_;
};

// `hapvox ARGS` refused: exit 2, `expected` its one line, and no file at `output`.
void expect_refused(const std::string& args, const std::string& expected,
                    const std::string& output) {
  const testing::CommandResult r = run_hapvox(args);
  EXPECT_EQ(r.exit_code, 2) << args;
  EXPECT_EQ(r.err, "hapvox: error: " + expected + "\n") << args;
  EXPECT_FALSE(std::filesystem::exists(output)) << args;
}

TEST(DeviceBridgeCli, DeviceSimThroughTheBridgeGetsTheDirectReplaysForces) {
  const std::string dir = scratch_dir();
  ASSERT_EQ(run_hapvox("trace make press-release -o " + dir +
                       "/press.csv --start-mm 24,24,29 --travel-mm 3.5 --hold-s 0.3")
                .exit_code,
            0);
  add_turning_stylus(dir + "/press.csv");
  const std::string tool = " --volume block:dims=48 --tool-diameter-mm 8 -q" + kTurn;
  ASSERT_EQ(
      run_hapvox("replay " + dir + "/press.csv" + tool + " -o " + dir + "/direct.h5").exit_code, 0);
  const std::uint16_t port = free_port();
  const std::string device = "udp:127.0.0.1:" + std::to_string(port);
  LiveSession hapvox(port, "replay --device " + device + tool + " --realtime --no-mlock -o " + dir +
                               "/live.h5 --trace-out " + dir + "/live.csv");
  const testing::CommandResult sim =
      run_hapvox("device-sim " + dir + "/press.csv" + kTurn + " --to " + device + " --forces-out " +
                 dir + "/forces.csv");
  const testing::CommandResult live = hapvox.finish();
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  ASSERT_EQ(live.exit_code, 0) << live.err;
  EXPECT_NE(sim.out.find("round trip       p50 "), std::string::npos) << sim.out;
  EXPECT_NE(live.out.find("; ended by the sender"), std::string::npos) << live.out;

  // A trip ramps ~200 ticks (321 of 501 were left in a fresh-clone ASan run with builds
  // beside it): the hold keeps some hundred at least.
  EXPECT_GE(expect_direct_forces(dir + "/forces.csv", dir + "/direct.h5"), 100u);
  // The live session records what came: its rows name the packet each tick used.
  const std::vector<double> sequence =
      haptics::read_session_column(dir + "/live.h5", "/device_sequence");
  ASSERT_FALSE(sequence.empty());
  EXPECT_EQ(sequence.front(), 0.0);
  const haptics::SessionInfo info = haptics::read_session_info(dir + "/live.h5");
  EXPECT_TRUE(info.complete);
  bool has_round_trip = false;
  for (const auto& [name, value] : info.attributes) {
    if (name == "bridge_round_trip_p99_us") has_round_trip = std::stod(value) > 0.0;
    if (name == "bridge_lost") {
      EXPECT_EQ(value, "0");
    }
  }
  EXPECT_TRUE(has_round_trip);
  // The stylus orientation came through the bridge too: each tick holds the orientation the
  // direct replay has for the sample its packet carried (the end packet: the last sample's).
  const std::vector<double> turn =
      haptics::read_session_column(dir + "/live.h5", "/device_orientation");
  const std::vector<double> direct_turn =
      haptics::read_session_column(dir + "/direct.h5", "/device_orientation");
  ASSERT_EQ(turn.size(), 4 * sequence.size());
  const std::size_t samples = direct_turn.size() / 4;
  for (std::size_t row = 0; row < sequence.size(); ++row) {
    const std::size_t k = std::min(static_cast<std::size_t>(sequence[row]), samples - 1);
    for (int c = 0; c < 4; ++c) ASSERT_EQ(turn[4 * row + c], direct_turn[4 * k + c]) << row;
  }

  // The trace the live session recorded, replayed in lockstep, steps the model through the
  // same positions tick for tick: the same forces, bit for bit, on every tick sent with the
  // same ramp factor (a realtime tick that tripped the watchdog, or fell silent, was ramped
  // where the lockstep replay is not: those are the ticks that may differ).
  // Its trace (qw,qx,qy,qz beside t,x,y,z) carries the orientation too.
  ASSERT_EQ(run_hapvox("replay " + dir + "/live.csv" + tool + " -o " + dir + "/again.h5").exit_code,
            0);
  const std::vector<double> again_turn =
      haptics::read_session_column(dir + "/again.h5", "/device_orientation");
  ASSERT_EQ(again_turn.size(), turn.size());
  for (std::size_t i = 0; i < turn.size(); ++i) EXPECT_NEAR(again_turn[i], turn[i], 1e-15) << i;
  testing::expect_same_columns(
      dir + "/live.h5", dir + "/again.h5",
      {"/tool_position_mm", "/displacement_mm", "/contact_area_mm2", "/contact"});
  // Each watchdog trip on a loaded machine ramps ~200 ticks (439 of 579 were left in a
  // fresh-clone ASan run with builds beside it): some hundred at least.
  EXPECT_GE(testing::expect_same_forces_at_same_ramp(dir + "/live.h5", dir + "/again.h5"), 100u);
}

// replay --device --model fem: a device program presses Nakao's proxy mesh through the
// bridge, the FEM on its own thread; it feels what a lockstep replay of the same press feels.
TEST(DeviceBridgeCli, ADeviceProgramPressesTheProxyMeshThroughTheBridge) {
  const std::string dir = scratch_dir();
  // The block fills its box (the FEM presses the mesh's outer faces, the top at z = 47.5):
  // the 8 mm tool from 1.5 mm clear to 2 mm in, held there.
  ASSERT_EQ(run_hapvox("trace make press-release -o " + dir +
                       "/press.csv --start-mm 24,24,53 --travel-mm 3.5 --hold-s 0.3")
                .exit_code,
            0);
  const std::string fem = " --volume block:dims=48,fill=1 --model fem --materials " +
                          testing::source_path("data/clay_block.toml") +
                          " --no-tool-refine --tool-diameter-mm 8 -q";
  const testing::CommandResult direct =
      run_hapvox("replay " + dir + "/press.csv" + fem + " -o " + dir + "/direct.h5");
  ASSERT_EQ(direct.exit_code, 0) << direct.err;
  const std::uint16_t port = free_port();
  const std::string device = "udp:127.0.0.1:" + std::to_string(port);
  LiveSession hapvox(
      port, "replay --device " + device + fem + " --realtime --no-mlock -o " + dir + "/live.h5");
  const testing::CommandResult sim = run_hapvox("device-sim " + dir + "/press.csv --to " + device);
  const testing::CommandResult live = hapvox.finish();
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  ASSERT_EQ(live.exit_code, 0) << live.err;
  EXPECT_NE(live.out.find("replayed " + device +
                          " on block:dims=48,fill=1 (proxy FEM, linear "
                          "press)"),
            std::string::npos)
      << live.out;
  const haptics::SessionInfo info = haptics::read_session_info(dir + "/live.h5");
  EXPECT_TRUE(info.complete);
  std::map<std::string, std::string> attributes(info.attributes.begin(), info.attributes.end());
  EXPECT_EQ(attributes["model"], "fem");
  EXPECT_EQ(attributes["fem_schedule"], "own thread");
  EXPECT_EQ(attributes["device"], device);
  EXPECT_GT(std::stoll(attributes["fem_steps"]), 10);
  EXPECT_GT(std::stoll(attributes["bridge_fresh"]), 500);
  // The press pushes the tool back out (+z) and is felt about as the lockstep replay feels
  // it (the FEM thread steps at its own times, so not bit for bit).
  auto peak_up_n = [](const std::string& session) {
    double peak = 0.0;
    const std::vector<double> force = haptics::read_session_column(session, "/force_n");
    for (std::size_t k = 0; k + 2 < force.size(); k += 3) peak = std::max(peak, force[k + 2]);
    return peak;
  };
  const double direct_n = peak_up_n(dir + "/direct.h5");
  ASSERT_GT(direct_n, 0.05);
  EXPECT_NEAR(peak_up_n(dir + "/live.h5"), direct_n, 0.25 * direct_n);
}

TEST(DeviceBridgeCli, BadFlagsAreOneLineAndMakeNoFile) {
  const std::string dir = scratch_dir();
  ASSERT_EQ(run_hapvox("trace make press -o " + dir + "/t.csv").exit_code, 0);
  const std::string out = " -o " + dir + "/s.h5";
  auto expect_error = [&](const std::string& args, const std::string& expected) {
    expect_refused(args, expected, dir + "/s.h5");
  };
  const std::string volume = " --volume block:dims=48";
  expect_error("replay --device udp:127.0.0.1:47001" + volume + out,
               "--device: needs --realtime (a live device has no lockstep)");
  expect_error("replay " + dir + "/t.csv --device udp:127.0.0.1:47001 --realtime" + volume + out,
               "--device: takes the place of a trace file: give one or the other");
  expect_error("replay --device udp:127.0.0.1:47001 --realtime --fit" + volume + out,
               "--fit: needs a trace file (a live device's path is not known ahead)");
  expect_error("replay --device udp:127.0.0.1:47001 --realtime --model fem" + volume + out,
               "--materials: --model fem needs one");
  expect_error(
      "replay --device udp:127.0.0.1:47001 --realtime --model fem --interaction grab "
      "--materials " +
          testing::source_path("data/clay_block.toml") + volume + out,
      "--interaction: a live session presses with the FEM model (a grab holds what lies "
      "within reach of a trace's first position, which a live session has not)");
  expect_error("replay --realtime" + volume + out,
               "trace: a trace file is needed (or --device udp:HOST:PORT)");
  expect_error(
      "replay --device udp:127.0.0.1:47001 --realtime --silence-timeout-s 0" + volume + out,
      "--silence-timeout-s: must lie in (0, 1], not 0");
  // A port already in use.
  const haptics::UdpSocket taken = haptics::UdpSocket::bound({"127.0.0.1", 0}, "test");
  const std::string port = std::to_string(taken.local_port());
  expect_error("replay --device udp:127.0.0.1:" + port + " --realtime" + volume + out,
               "--device: cannot listen on 127.0.0.1:" + port + ": Address already in use");
  expect_error("replay " + dir + "/t.csv --trace-out " + dir + "/u.csv" + volume + out,
               "--trace-out: needs --device (a trace replay has its trace already)");
  expect_error("device-sim " + dir + "/t.csv --to udp:127.0.0.1:47001 --drop 0.9",
               "--drop: must lie in [0, 0.5]");
}

// --device-key FILE: missing, empty or a directory is one line naming the file, for hapvox
// and device-sim alike; --device-peer's spec and both flags without --device likewise.
TEST(DeviceBridgeCli, KeyAndPeerMistakesAreOneLineAndMakeNoFile) {
  const std::string dir = scratch_dir();
  ASSERT_EQ(run_hapvox("trace make press -o " + dir + "/t.csv").exit_code, 0);
  std::ofstream(dir + "/empty.key").close();
  std::filesystem::create_directories(dir + "/keys");
  const std::string out = " -o " + dir + "/s.h5";
  auto expect_error = [&](const std::string& args, const std::string& expected) {
    expect_refused(args, expected, dir + "/s.h5");
  };
  const std::string live = "replay --device udp:127.0.0.1:47001 --realtime --volume block:dims=48";
  expect_error(live + " --device-key " + dir + "/none.key" + out,
               dir + "/none.key: cannot open file");
  expect_error(live + " --device-key " + dir + "/empty.key" + out,
               dir +
                   "/empty.key: the key file is empty (it holds the shared key's bytes, e.g. "
                   "32 from /dev/urandom)");
  expect_error(live + " --device-key " + dir + "/keys" + out, dir + "/keys: is a directory");
  expect_error(live + " --device-peer 127.0.0.1" + out,
               "--device-peer: '127.0.0.1': expected udp:HOST:PORT (e.g. udp:127.0.0.1:47001 or "
               "udp:[::1]:47001)");
  expect_error(live + " --device-peer udp:127.0.0.1:0" + out,
               "--device-peer: port 0: name the port the device sends from");
  expect_error(
      "replay " + dir + "/t.csv --volume block:dims=48 --device-key " + dir + "/empty.key" + out,
      "--device-key: needs --device (the bridge's shared key)");
  expect_error("replay " + dir + "/t.csv --volume block:dims=48 --device-peer 127.0.0.1:5" + out,
               "--device-peer: needs --device (the bridge's one sender)");
  expect_error(
      "device-sim " + dir + "/t.csv --to udp:127.0.0.1:47001 --device-key " + dir + "/empty.key",
      dir +
          "/empty.key: the key file is empty (it holds the shared key's bytes, e.g. "
          "32 from /dev/urandom)");
  expect_error(
      "device-sim " + dir + "/t.csv --to udp:127.0.0.1:47001 --device-key " + dir + "/none.key",
      dir + "/none.key: cannot open file");
}

std::map<std::string, std::string> session_attributes(const std::string& path) {
  const haptics::SessionInfo info = haptics::read_session_info(path);
  EXPECT_TRUE(info.complete) << path;
  return std::map<std::string, std::string>(info.attributes.begin(), info.attributes.end());
}

// replay --device --device-key K: a device-sim with another key is refused packet by packet
// (it hears nothing back, the tool does not move, and the session waits on); the one with K
// then drives the tool and gets the direct replay's forces, tagged.
TEST(DeviceBridgeCli, AKeyedSessionTakesOnlyTheKeysDevice) {
  const std::string dir = scratch_dir();
  ASSERT_EQ(run_hapvox("trace make press-release -o " + dir +
                       "/press.csv --start-mm 24,24,29 --travel-mm 3.5 --hold-s 0.3")
                .exit_code,
            0);
  std::string key_bytes(32, '\0');
  for (std::size_t i = 0; i < key_bytes.size(); ++i) key_bytes[i] = static_cast<char>(37 * i + 11);
  std::ofstream(dir + "/right.key", std::ios::binary) << key_bytes;
  std::ofstream(dir + "/wrong.key", std::ios::binary) << "not the key";
  const std::string tool = " --volume block:dims=48 --tool-diameter-mm 8 -q";
  ASSERT_EQ(
      run_hapvox("replay " + dir + "/press.csv" + tool + " -o " + dir + "/direct.h5").exit_code, 0);
  const std::uint16_t port = free_port();
  const std::string device = "udp:127.0.0.1:" + std::to_string(port);
  LiveSession hapvox(port, "replay --device " + device + " --device-key " + dir + "/right.key" +
                               tool + " --realtime --no-mlock -o " + dir + "/live.h5");
  const testing::CommandResult wrong =
      run_hapvox("device-sim " + dir + "/press.csv --to " + device + " --no-end --device-key " +
                 dir + "/wrong.key");
  const testing::CommandResult right =
      run_hapvox("device-sim " + dir + "/press.csv --to " + device + " --device-key " + dir +
                 "/right.key --forces-out " + dir + "/forces.csv");
  const testing::CommandResult live = hapvox.finish();
  ASSERT_EQ(wrong.exit_code, 0) << wrong.err;
  ASSERT_EQ(right.exit_code, 0) << right.err;
  ASSERT_EQ(live.exit_code, 0) << live.err;
  EXPECT_NE(wrong.out.find(" 0 answered, 0 force packets back, keyed"), std::string::npos)
      << wrong.out;
  EXPECT_NE(right.out.find(", keyed\n"), std::string::npos) << right.out;
  EXPECT_EQ(right.out.find("refused"), std::string::npos) << right.out;  // every tag right
  EXPECT_NE(live.out.find("; ended by the sender"), std::string::npos) << live.out;
  EXPECT_NE(live.out.find(" unauthenticated; device 127.0.0.1:"), std::string::npos) << live.out;

  EXPECT_GE(expect_direct_forces(dir + "/forces.csv", dir + "/direct.h5"), 100u);
  std::map<std::string, std::string> attributes = session_attributes(dir + "/live.h5");
  EXPECT_EQ(attributes["bridge_keyed"], "1");
  EXPECT_GT(std::stoll(attributes["bridge_unauthenticated"]), 500);  // the wrong key's
  EXPECT_EQ(attributes["bridge_foreign"], "0");
  EXPECT_EQ(attributes["bridge_late"], "0");
  EXPECT_EQ(attributes["bridge_lost"], "0");
  EXPECT_EQ(attributes["bridge_out_of_window"], "0");
  EXPECT_EQ(attributes["bridge_peer"].rfind("127.0.0.1:", 0), 0u) << attributes["bridge_peer"];
  // No tick used a wrong-key packet: the session's first position is the right device's.
  const std::vector<double> sequence =
      haptics::read_session_column(dir + "/live.h5", "/device_sequence");
  ASSERT_FALSE(sequence.empty());
  EXPECT_EQ(sequence.front(), 0.0);
  EXPECT_GT(std::stoll(attributes["bridge_fresh"]), 500);
}

// replay --device --device-peer HOST:PORT: a device-sim sending from any other port is
// never answered and never moves the tool; the run ends without a tick, so it writes nothing
// and says what the bridge refused (exit 2).
TEST(DeviceBridgeCli, ADevicePeerTakesNoOtherSender) {
  const std::string dir = scratch_dir();
  ASSERT_EQ(run_hapvox("trace make press -o " + dir + "/t.csv").exit_code, 0);
  const std::uint16_t peer_port = free_port();  // nobody sends from it
  const std::uint16_t port = free_port();
  const std::string device = "udp:127.0.0.1:" + std::to_string(port);
  LiveSession hapvox(
      port, "replay --device " + device + " --device-peer 127.0.0.1:" + std::to_string(peer_port) +
                " --end-after-silence-s 3 --volume block:dims=48 -q --realtime --no-mlock "
                "-o " +
                dir + "/live.h5");
  const testing::CommandResult sim = run_hapvox("device-sim " + dir + "/t.csv --to " + device);
  const testing::CommandResult live = hapvox.finish();
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  EXPECT_EQ(live.exit_code, 2) << live.err;
  EXPECT_NE(sim.out.find("nothing answered"), std::string::npos) << sim.out;
  const std::string head = "hapvox: error: " + device +
                           ": no position arrived before the run ended (the bridge refused ";
  ASSERT_EQ(live.err.rfind(head, 0), 0u) << live.err;
  const long long foreign = std::stoll(live.err.substr(head.size()));
  EXPECT_GT(foreign, 100);
  EXPECT_NE(live.err.find(" datagrams from other senders, 0 unauthenticated, 0 out of the "
                          "sequence window): no tick ran, nothing written to " +
                          dir + "/live.h5\n"),
            std::string::npos)
      << live.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/live.h5"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/live.h5.partial"));
}

}  // namespace
}  // namespace hapvox
