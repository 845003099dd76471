// hapvox device-sim TRACE --to udp:HOST:PORT: the device bridge's reference client
// (haptics/bridge_client.h). It plays a trace as a device's servo loop would, one position
// packet per tick, takes the force answers and reports their round trip; --forces-out keeps
// every answer. With --drop/--reorder/--duplicate it impairs its own stream (for tests of
// the bridge's counting); with --device-key FILE it tags its packets and checks the answers'
// tags with hapvox's shared key.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "haptics/bridge_client.h"
#include "haptics/trace_resample.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct DeviceSimFlags {
  std::string trace_path;
  std::string to;
  std::string forces_out;
  std::string device_key;
  TraceFlags trace;
  haptics::BridgeClientOptions options;
  bool no_end = false;
  bool released = false;
};

void check_fraction(double value, const char* flag) {
  if (!(value >= 0.0 && value <= 0.5)) throw InputError(flag, "must lie in [0, 0.5]");
}

void write_answers(const haptics::BridgeClientResult& result, const std::string& path) {
  std::ostringstream out;
  {
    out << "sequence,answered,fx,fy,fz,status,tick,round_trip_ns\n";
    out.precision(17);
    for (std::size_t k = 0; k < result.answers.size(); ++k) {
      const haptics::BridgeAnswer& a = result.answers[k];
      out << k << ',' << (a.answered ? 1 : 0) << ',' << a.force_n.x() << ',' << a.force_n.y() << ','
          << a.force_n.z() << ',' << a.status << ',' << a.tick << ',' << a.round_trip_ns << '\n';
    }
  }
  engine::io::write_text_atomically(path, out.str());
}

void run_device_sim(const DeviceSimFlags& f) {
  check_fraction(f.options.drop_fraction, "--drop");
  check_fraction(f.options.reorder_fraction, "--reorder");
  check_fraction(f.options.duplicate_fraction, "--duplicate");
  if (!(f.trace.rate_hz >= 100.0 && f.trace.rate_hz <= 10e3)) {
    throw InputError("--rate-hz", "must lie in [100, 10000] Hz");
  }
  if (!(f.options.pause_s >= 0.0) || !std::isfinite(f.options.pause_s)) {
    throw InputError("--pause-s", "must be zero or positive");
  }
  const haptics::UdpAddress to = haptics::parse_udp_address(f.to);
  haptics::BridgeClientOptions options = f.options;
  if (!f.device_key.empty()) options.key = haptics::BridgeKey::from_file(f.device_key);
  if (!f.forces_out.empty()) {
    check_output_path(f.forces_out, "--forces-out");
    check_outputs_spare_inputs({{f.forces_out, "--forces-out", ""}}, {{f.trace_path, "trace"}});
  }
  const haptics::Trace trace = haptics::read_trace(f.trace_path, f.trace.columns());
  haptics::ResampleOptions resample_options;
  resample_options.rate_hz = f.trace.rate_hz;
  resample_options.max_gap_s = f.trace.max_gap_s;
  const haptics::ResampledTrace ticks = haptics::resample(trace, resample_options, f.trace_path);
  const haptics::SocketAddress address = haptics::resolve_udp_address(to, "--to");
  haptics::UdpAddress local;
  local.host = address.storage.ss_family == AF_INET6 ? "::" : "0.0.0.0";
  haptics::UdpSocket socket = haptics::UdpSocket::bound(local, "device-sim");
  options.send_end = !f.no_end;
  options.buttons = f.released ? 0u : haptics::kButtonDeadMan;
  const haptics::BridgeClientResult result =
      haptics::play_through_bridge(ticks, socket, address, options);
  if (!f.forces_out.empty()) write_answers(result, f.forces_out);
  std::printf("played %s to %s: %zu ticks at %.0f Hz in %.3f s\n", f.trace_path.c_str(),
              f.to.c_str(), ticks.position_mm.size(), ticks.rate_hz, result.wall_s);
  std::printf(
      "  packets          %llu sent (%llu dropped, %llu reordered, %llu duplicated on "
      "purpose); %llu answered, %llu force packets back%s\n",
      static_cast<unsigned long long>(result.sent), static_cast<unsigned long long>(result.dropped),
      static_cast<unsigned long long>(result.reordered),
      static_cast<unsigned long long>(result.duplicated),
      static_cast<unsigned long long>(result.answered),
      static_cast<unsigned long long>(result.force_packets), options.key ? ", keyed" : "");
  if (result.unauthenticated > 0) {
    std::printf("  refused          %llu answers with a wrong or missing tag\n",
                static_cast<unsigned long long>(result.unauthenticated));
  }
  std::printf("  round trip       p50 %.1f us, p99 %.1f us, max %.1f us (%llu)\n",
              1e-3 * static_cast<double>(result.round_trip.percentile_ns(50.0)),
              1e-3 * static_cast<double>(result.round_trip.percentile_ns(99.0)),
              1e-3 * static_cast<double>(result.round_trip.max_ns()),
              static_cast<unsigned long long>(result.round_trip.count()));
  if (result.answered == 0) {
    std::printf("  nothing answered: is hapvox listening on %s?\n", f.to.c_str());
  }
}

}  // namespace

void add_device_sim_command(CLI::App& app) {
  auto flags = std::make_shared<DeviceSimFlags>();
  CLI::App* cmd = app.add_subcommand(
      "device-sim",
      "Play a trace through the device bridge as a haptic device would (the bridge's "
      "reference client): a position packet per tick, the force answers back");
  cmd->add_option("trace", flags->trace_path, "Trace file (.csv, .h5, H3D DeviceLog)")->required();
  cmd->add_option("--to", flags->to, "udp:HOST:PORT where hapvox listens (--device)")->required();
  cmd->add_option("--forces-out", flags->forces_out,
                  "CSV of every answer: sequence, force, status, tick, round trip");
  cmd->add_option("--device-key", flags->device_key,
                  "A file of the shared key's bytes (hapvox's --device-key): packets carry an "
                  "HMAC-SHA256 tag, answers without the right one are refused");
  flags->trace.add_to(*cmd);
  cmd->add_option("--drop", flags->options.drop_fraction, "Fraction of packets not sent")
      ->capture_default_str();
  cmd->add_option("--reorder", flags->options.reorder_fraction,
                  "Fraction of packets sent after the next one")
      ->capture_default_str();
  cmd->add_option("--duplicate", flags->options.duplicate_fraction,
                  "Fraction of packets sent twice")
      ->capture_default_str();
  cmd->add_option("--seed", flags->options.seed, "Seed of the impairments")->capture_default_str();
  cmd->add_option("--pause-at-s", flags->options.pause_at_s,
                  "Fall silent this far into the trace (< 0: never)")
      ->capture_default_str();
  cmd->add_option("--pause-s", flags->options.pause_s, "For this long")->capture_default_str();
  cmd->add_flag("--no-end", flags->no_end, "Do not end hapvox's session at the trace's end");
  cmd->add_flag("--released", flags->released,
                "Send the dead-man button released (hapvox sends no force)");
  cmd->callback([flags] { run_device_sim(*flags); });
}

}  // namespace hapvox::cli
