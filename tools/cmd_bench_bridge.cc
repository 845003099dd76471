// hapvox bench bridge: the device bridge's round trip on loopback, as a device sees it: a
// position packet out, the force packet that answers it back, one per millisecond as a
// servo loop sends them. hapvox runs its realtime loop on an elastic press (the force stage
// really computes), and the bench times each round trip (Google Benchmark, manual time:
// medians of repetitions) and keeps every one in a histogram for p50/p99. Beside it, in the
// same run, the naive design: ticks on the loop's own 1 kHz clock taking whatever arrived
// since the last one, so a position waits for the next tick.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <thread>

#include "engine/errors.h"
#include "engine/volume_io.h"
#include "haptics/bridge_device.h"
#include "haptics/realtime.h"
#include "haptics/voxel_model.h"
#include "tools/bench.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BridgeBenchFlags {
  int round_trips = 2000;
  int repetitions = 5;
};

struct ModeResult {
  double median_ns = 0.0;  // Google Benchmark's median of the repetitions' means
  haptics::LatencyHistogram round_trip;
  std::uint64_t unanswered = 0;
};

std::uint64_t now_ns() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
          .count());
}

// hapvox's side: a realtime elastic press behind a bridge on a free loopback port, until
// `stop`.
class BridgeServer {
 public:
  explicit BridgeServer(bool device_paced)
      : field_(engine::generate_volume("block:dims=48")), model_(field_, tool()) {
    haptics::BridgeOptions options;
    options.device_paced = device_paced;
    options.end_after_silence_s = 0.0;
    options.stop = &stop_;
    device_ = std::make_unique<haptics::BridgeDevice>(
        haptics::UdpSocket::bound({"127.0.0.1", 0}, "bench"), haptics::DeviceTransform{}, options);
    thread_ = std::thread([this] {
      haptics::RealtimeOptions realtime;
      realtime.scheduler.lock_memory = false;
      realtime.stop = &stop_;
      haptics::replay_realtime(model_, *device_, haptics::DeviceLimits{}, nullptr, {}, nullptr,
                               nullptr, nullptr, realtime);
    });
  }
  ~BridgeServer() {
    stop_.store(true);
    thread_.join();
  }
  std::uint16_t port() const { return device_->local_port(); }

 private:
  static engine::ToolForceOptions tool() {
    engine::ToolForceOptions options;
    options.tool.diameter_mm = 8.0;
    return options;
  }
  std::atomic<bool> stop_{false};
  engine::DensityField field_;
  engine::ToolForceModel model_;
  std::unique_ptr<haptics::BridgeDevice> device_;
  std::thread thread_;
};

// One client socket per server, across repetitions: the bridge takes packets from the one
// sender it bound first (a new socket's would be dropped as another sender's).
void round_trips(benchmark::State& state, haptics::UdpSocket& socket, std::uint16_t port,
                 ModeResult& result) {
  const haptics::SocketAddress to = haptics::resolve_udp_address({"127.0.0.1", port}, "bench");
  static std::uint32_t sequence = 0;  // fresh across repetitions: hapvox's window goes on
  std::uint8_t out[haptics::kPositionPacketBytes];
  std::uint8_t in[haptics::kBridgeMaxDatagramBytes];
  auto slot = Clock::now();
  for (auto _ : state) {
    // One packet a millisecond, as a servo loop sends them; the wait is not timed.
    slot += std::chrono::milliseconds(1);
    haptics::sleep_then_spin_until(slot);
    haptics::PositionPacket packet;
    packet.header.sequence = ++sequence;
    packet.position_mm = haptics::Vec3d(24.0, 24.0, 26.0);  // pressed 1.5 mm into the block
    packet.buttons = haptics::kButtonDeadMan;
    packet.header.sent_ns = now_ns();
    socket.send_to(out, haptics::encode_position(packet, out), to);
    bool answered = false;
    std::uint64_t trip_ns = 0;
    const auto give_up = Clock::now() + std::chrono::milliseconds(50);
    while (!answered && Clock::now() < give_up) {
      const long length = socket.receive(in, sizeof in, nullptr);
      if (length < 0) continue;  // spin: the client measures, it does not sleep
      haptics::ForcePacket force;
      if (haptics::parse_force(in, static_cast<std::size_t>(length), &force) ==
              haptics::PacketError::none &&
          force.echo_sequence == sequence) {
        trip_ns = now_ns() - force.echo_sent_ns;
        answered = true;
      }
    }
    if (!answered) {
      ++result.unanswered;
      state.SetIterationTime(0.05);
      continue;
    }
    result.round_trip.add(static_cast<std::int64_t>(trip_ns));
    state.SetIterationTime(1e-9 * static_cast<double>(trip_ns));
  }
}

void run_bench_bridge(const BridgeBenchFlags& f) {
  if (f.round_trips < 100) throw InputError("--round-trips", "must be at least 100");
  if (f.repetitions < 1) throw InputError("--repetitions", "must be at least 1");
  init_benchmark(0.0, f.repetitions);
  ModeResult paced, clocked;
  {
    BridgeServer paced_server(true);
    BridgeServer clocked_server(false);
    const std::uint16_t paced_port = paced_server.port();
    const std::uint16_t clocked_port = clocked_server.port();
    haptics::UdpSocket paced_client = haptics::UdpSocket::bound({"127.0.0.1", 0}, "bench");
    haptics::UdpSocket clocked_client = haptics::UdpSocket::bound({"127.0.0.1", 0}, "bench");
    std::map<std::string, double> median_ns = measure_manual_time(
        {{"bridge/device_paced",
          [&](benchmark::State& s) { round_trips(s, paced_client, paced_port, paced); }},
         {"bridge/loop_clocked_baseline",
          [&](benchmark::State& s) { round_trips(s, clocked_client, clocked_port, clocked); }}},
        f.round_trips / f.repetitions);
    paced.median_ns = median_ns["bridge/device_paced"];
    clocked.median_ns = median_ns["bridge/loop_clocked_baseline"];
  }
  auto us = [](std::uint64_t ns) { return 1e-3 * static_cast<double>(ns); };
  std::printf("\nbridge round trip on loopback (position out, its force back), %d per mode\n",
              f.round_trips);
  std::printf("%-28s %10s %10s %10s %10s %10s\n", "mode", "median", "p50", "p99", "max",
              "unanswered");
  for (const auto& [name, r] : {std::pair<const char*, const ModeResult&>{"device paced", paced},
                                {"loop clocked (baseline)", clocked}}) {
    std::printf("%-28s %8.1f us %7.1f us %7.1f us %7.1f us %10llu\n", name, 1e-3 * r.median_ns,
                us(r.round_trip.percentile_ns(50.0)), us(r.round_trip.percentile_ns(99.0)),
                us(r.round_trip.max_ns()), static_cast<unsigned long long>(r.unanswered));
  }
  const double p99 = us(paced.round_trip.percentile_ns(99.0));
  std::printf("p99 ratio baseline / paced: %.1fx; goal p99 <= 200 us: %s\n",
              us(clocked.round_trip.percentile_ns(99.0)) / std::max(p99, 1e-9),
              p99 <= 200.0 ? "met" : "NOT met");
}

}  // namespace

void add_bench_bridge_command(CLI::App& bench) {
  auto flags = std::make_shared<BridgeBenchFlags>();
  CLI::App* cmd = bench.add_subcommand(
      "bridge",
      "Device bridge round trip on loopback (p50/p99), device-paced beside the "
      "loop-clocked baseline");
  cmd->add_option("--round-trips", flags->round_trips, "Round trips per mode")
      ->capture_default_str();
  cmd->add_option("--repetitions", flags->repetitions, "Google Benchmark repetitions")
      ->capture_default_str();
  cmd->callback([flags] { run_bench_bridge(*flags); });
}

}  // namespace hapvox::cli
