// `hapvox replay --device udp:HOST:PORT`: the live device behind the bridge
// (haptics/bridge_device.h) in place of a trace, its flags (--device-peer, --device-key:
// who may drive the tool), counters and report.

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>

#include "engine/errors.h"
#include "tools/replay_command.h"

namespace hapvox::cli {
namespace {

std::atomic<bool> g_stop_requested{false};

extern "C" void request_stop(int) { g_stop_requested.store(true); }

// Packets refused as malformed (PacketError 0 is none; bad_tag is counted apart, as
// unauthenticated).
std::uint64_t malformed_total(const haptics::BridgeCounters& c) {
  std::uint64_t malformed = 0;
  for (int e = 1; e < haptics::kPacketErrorCount; ++e) malformed += c.malformed[e];
  return malformed;
}

}  // namespace

Eigen::Vector3d above_volume_mm(const engine::DensityField& field, double tool_radius_mm) {
  const Eigen::Vector3d lo = field.world_min_mm(), hi = field.world_max_mm();
  return {0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), hi.z() + tool_radius_mm + 2.0};
}

void check_bridge_flags(const ReplayFlags& f) {
  if (!f.trace_path.empty()) {
    throw InputError("--device", "takes the place of a trace file: give one or the other");
  }
  if (!f.realtime) throw InputError("--device", "needs --realtime (a live device has no lockstep)");
  if (f.transform.fit) {
    throw InputError("--fit", "needs a trace file (a live device's path is not known ahead)");
  }
  if (!(f.silence_timeout_s > 0.0 && f.silence_timeout_s <= 1.0)) {
    throw InputError("--silence-timeout-s", "must lie in (0, 1] s");
  }
  if (!(f.end_after_silence_s >= 0.0) || !std::isfinite(f.end_after_silence_s)) {
    throw InputError("--end-after-silence-s", "must be zero (never) or positive");
  }
  if (!(f.trace.rate_hz >= 100.0 && f.trace.rate_hz <= 10e3)) {
    throw InputError("--rate-hz", "a live device's loop runs at 100 to 10000 Hz");
  }
  haptics::parse_udp_address(f.device);  // its mistakes before anything is read or made
  if (!f.device_peer.empty()) resolve_device_peer(f.device_peer);
  if (!f.device_key.empty()) haptics::BridgeKey::from_file(f.device_key);  // read, dropped
  if (!f.trace_out.empty()) check_output_path(f.trace_out, "--trace-out");
}

haptics::SocketAddress resolve_device_peer(const std::string& spec) {
  haptics::UdpAddress peer;
  try {
    peer = haptics::parse_udp_address(spec.rfind("udp:", 0) == 0 ? spec : "udp:" + spec);
  } catch (const InputError& e) {
    throw InputError("--device-peer", "'" + printable(spec) + "': " + e.problem());
  }
  if (peer.port == 0) {
    throw InputError("--device-peer", "port 0: name the port the device sends from");
  }
  return haptics::resolve_udp_address(peer, "--device-peer");
}

void write_recorded_trace(const std::string& session_path, const std::string& trace_path) {
  const std::vector<double> time_s = haptics::read_session_column(session_path, "/time_s");
  const std::vector<double> position =
      haptics::read_session_column(session_path, "/device_position_mm");
  haptics::Trace trace;
  trace.time_s = time_s;
  trace.position_mm.reserve(time_s.size());
  for (std::size_t k = 0; k < time_s.size(); ++k) {
    trace.position_mm.emplace_back(position[3 * k], position[3 * k + 1], position[3 * k + 2]);
  }
  // The stylus orientation of each tick, where the device reported one (a bridge's packets).
  const std::vector<std::string> datasets = haptics::read_session_info(session_path).datasets;
  if (std::find(datasets.begin(), datasets.end(), "/device_orientation") != datasets.end()) {
    const std::vector<double> q = haptics::read_session_column(session_path, "/device_orientation");
    for (std::size_t k = 0; k < time_s.size(); ++k) {
      trace.orientation.emplace_back(q[4 * k], q[4 * k + 1], q[4 * k + 2], q[4 * k + 3]);
    }
  }
  if (trace.time_s.size() < 2) {
    std::fprintf(stderr, "hapvox: warning: --trace-out: %zu ticks, no trace written\n",
                 trace.time_s.size());
    // An earlier session's trace there would pass for this one's.
    std::error_code ignored;
    std::filesystem::remove(trace_path, ignored);
    return;
  }
  haptics::write_csv_trace(trace, trace_path);
}

std::unique_ptr<haptics::BridgeDevice> make_bridge_device(
    const ReplayFlags& f, const haptics::DeviceTransform& transform) {
  haptics::BridgeOptions options;
  options.rate_hz = f.trace.rate_hz;
  options.silence_timeout_s = f.silence_timeout_s;
  options.end_after_silence_s = f.end_after_silence_s;
  options.stop = &g_stop_requested;
  if (!f.device_peer.empty()) options.peer = resolve_device_peer(f.device_peer);
  if (!f.device_key.empty()) options.key = haptics::BridgeKey::from_file(f.device_key);
  haptics::UdpSocket socket =
      haptics::UdpSocket::bound(haptics::parse_udp_address(f.device), "--device");
  end_session_on_signals();
  return std::make_unique<haptics::BridgeDevice>(std::move(socket), transform, options);
}

const std::atomic<bool>* stop_request() { return &g_stop_requested; }

StopOnSignals::StopOnSignals() {
  g_stop_requested.store(false);
  interrupt_ = std::signal(SIGINT, request_stop);
  terminate_ = std::signal(SIGTERM, request_stop);
}

StopOnSignals::~StopOnSignals() {
  if (interrupt_ != SIG_ERR) std::signal(SIGINT, interrupt_);
  if (terminate_ != SIG_ERR) std::signal(SIGTERM, terminate_);
}

void end_session_on_signals() {
  // Ctrl-C or a kill ends the session after the tick under way; the file keeps every tick.
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);
}

void write_bridge_attributes(haptics::SessionWriter& session, const haptics::BridgeDevice& device) {
  const haptics::BridgeCounters& c = device.counters();
  auto count = [&](const char* name, std::uint64_t value) {
    session.set_attribute(std::string("bridge_") + name, static_cast<std::int64_t>(value));
  };
  count("datagrams", c.datagrams);
  count("fresh", c.fresh);
  count("late", c.late);
  count("duplicates", c.duplicates);
  count("lost", c.lost);
  count("out_of_window", c.out_of_window);
  count("foreign", c.foreign);
  count("unauthenticated", c.unauthenticated);
  count("keyed", device.keyed() ? 1 : 0);
  const std::optional<haptics::SocketAddress> peer = device.peer();
  session.set_attribute("bridge_peer", peer ? haptics::endpoint_text(*peer) : std::string());
  for (int e = 1; e < haptics::kPacketErrorCount; ++e) {
    if (e == static_cast<int>(haptics::PacketError::bad_tag)) continue;  // unauthenticated
    std::string name = haptics::packet_error_name(static_cast<haptics::PacketError>(e));
    for (char& ch : name) {
      if (ch == ' ') ch = '_';
    }
    count(("malformed_" + name).c_str(), c.malformed[e]);
  }
  count("malformed", malformed_total(c));
  count("held_ticks", c.held_ticks);
  count("silent_ticks", c.silent_ticks);
  count("silences", c.silences);
  count("released_ticks", c.released_ticks);
  count("answers", c.answers);
  count("send_failures", c.send_failures);
  count("ended_by_sender", c.ended_by_sender ? 1 : 0);
  const haptics::DurationStats trip = haptics::duration_stats(c.round_trip);
  count("round_trips", trip.count);
  session.set_attribute("bridge_round_trip_p50_us", trip.p50_us);
  session.set_attribute("bridge_round_trip_p99_us", trip.p99_us);
  session.set_attribute("bridge_round_trip_max_us", trip.max_us);
  const haptics::DurationStats answer = haptics::duration_stats(c.answer);
  session.set_attribute("bridge_answer_p50_us", answer.p50_us);
  session.set_attribute("bridge_answer_p99_us", answer.p99_us);
  session.set_attribute("bridge_answer_max_us", answer.max_us);
  session.set_attribute("silence_timeout_s", device.silence_timeout_s());
}

void print_bridge_lines(const haptics::BridgeDevice& device) {
  const haptics::BridgeCounters& c = device.counters();
  const std::uint64_t malformed = malformed_total(c);
  std::printf(
      "  bridge           %llu datagrams: %llu fresh, %llu late, %llu duplicates, %llu lost, "
      "%llu malformed; %llu ticks held, %llu silent (%llu silences)%s\n",
      static_cast<unsigned long long>(c.datagrams), static_cast<unsigned long long>(c.fresh),
      static_cast<unsigned long long>(c.late), static_cast<unsigned long long>(c.duplicates),
      static_cast<unsigned long long>(c.lost), static_cast<unsigned long long>(malformed),
      static_cast<unsigned long long>(c.held_ticks),
      static_cast<unsigned long long>(c.silent_ticks), static_cast<unsigned long long>(c.silences),
      c.ended_by_sender ? "; ended by the sender" : "");
  const std::optional<haptics::SocketAddress> peer = device.peer();
  std::printf(
      "  bridge refused   %llu from other senders, %llu out of the sequence window, %llu "
      "unauthenticated; device %s%s\n",
      static_cast<unsigned long long>(c.foreign), static_cast<unsigned long long>(c.out_of_window),
      static_cast<unsigned long long>(c.unauthenticated),
      peer ? haptics::endpoint_text(*peer).c_str() : "none", device.keyed() ? ", keyed" : "");
  print_stats_line("round trip", haptics::duration_stats(c.round_trip));
  print_stats_line("answer", haptics::duration_stats(c.answer));
}

}  // namespace hapvox::cli
