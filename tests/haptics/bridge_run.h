#pragma once
// The device bridge end to end on loopback, in one process, for the bridge's tests
// (bridge_device_test.cc, bridge_trust_test.cc): hapvox's realtime loop with a BridgeDevice
// on one side, the reference client (haptics/bridge_client.h) playing a trace on the other,
// and, if a test wants one, a third party sending beside them.

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "alloc_count.h"
#include "engine/volume_io.h"
#include "haptics/bridge_client.h"
#include "haptics/bridge_device.h"
#include "haptics/realtime.h"
#include "haptics/voxel_model.h"

namespace hapvox::haptics::bridge_testing {

// An 8 mm tool pressing 2 mm into the face of a 48^3 block (z = 23.5 mm) and holding.
inline ResampledTrace press_ticks(double hold_s) {
  TraceMakeOptions make;
  make.shape = TraceShape::kPressRelease;
  make.start_mm = Vec3d(24.0, 24.0, 29.0);
  make.travel_mm = 3.5;
  make.speed_mm_s = 10.0;
  make.hold_s = hold_s;
  return resample(make_trace(make));
}

inline engine::ToolForceOptions elastic_tool() {
  engine::ToolForceOptions options;
  options.tool.diameter_mm = 8.0;
  return options;
}

inline std::string temp_path(const std::string& name) {
  return (std::filesystem::path(::testing::TempDir()) / name).string();
}

struct BridgeRun {
  std::uint64_t force_thread_allocations = ~0ull;
  BridgeClientResult client;
  BridgeCounters bridge;
  std::optional<SocketAddress> peer;  // the device the bridge bound
  std::uint16_t client_port = 0;      // the client's socket's
  ReplaySummary summary;
  TimingSummary timing;
};

struct BridgeRunSetup {
  BridgeClientOptions client;
  BridgeOptions bridge = [] {
    BridgeOptions options;
    options.end_after_silence_s = 5.0;
    return options;
  }();
  /// Runs on a third thread while the client plays: `device` is the client's own socket
  /// (sending from it passes for the device), `to` where hapvox listens.
  std::function<void(UdpSocket& device, const SocketAddress& to)> beside;
  /// The bridge is told the client's address as its peer (BridgeOptions::peer).
  bool client_is_named_peer = false;
};

// hapvox listens on a free loopback port; the client plays `ticks` to it.
inline BridgeRun run_bridge_with(const ResampledTrace& ticks, const BridgeRunSetup& setup,
                                 const std::string& session_path) {
  const engine::DensityField field = engine::generate_volume("block:dims=48");
  const engine::ToolForceModel model(field, elastic_tool());
  BridgeRun run;
  UdpSocket socket = UdpSocket::bound({"127.0.0.1", 0}, "client");
  run.client_port = socket.local_port();
  BridgeOptions options = setup.bridge;
  if (setup.client_is_named_peer) {
    options.peer = resolve_udp_address({"127.0.0.1", run.client_port}, "test");
  }
  BridgeDevice device(UdpSocket::bound({"127.0.0.1", 0}, "test"), DeviceTransform{}, options);
  const SocketAddress to = resolve_udp_address({"127.0.0.1", device.local_port()}, "test");
  std::thread client([&] { run.client = play_through_bridge(ticks, socket, to, setup.client); });
  std::thread beside;
  if (setup.beside) beside = std::thread([&] { setup.beside(socket, to); });
  RealtimeOptions realtime;
  realtime.scheduler.lock_memory = false;
  std::uint64_t at_start = 0;
  realtime.hooks.loop_started = [&] { at_start = testing::allocations_on_this_thread; };
  realtime.hooks.loop_finished = [&] {
    run.force_thread_allocations = testing::allocations_on_this_thread - at_start;
  };
  SessionWriter session(session_path);
  run.summary = replay_realtime(model, device, DeviceLimits{}, &session, {}, nullptr, nullptr,
                                &run.timing, realtime);
  session.close();
  client.join();
  if (beside.joinable()) beside.join();
  run.bridge = device.counters();
  run.peer = device.peer();
  return run;
}

inline BridgeRun run_bridge(const ResampledTrace& ticks, const BridgeClientOptions& client_options,
                            const std::string& session_path) {
  BridgeRunSetup setup;
  setup.client = client_options;
  return run_bridge_with(ticks, setup, session_path);
}

inline std::vector<Vec3d> lockstep_forces(const ResampledTrace& ticks) {
  const engine::DensityField field = engine::generate_volume("block:dims=48");
  const engine::ToolForceModel model(field, elastic_tool());
  TraceDevice device(ticks, DeviceTransform{});
  const std::string path = temp_path("bridge_lockstep.h5");
  SessionWriter session(path);
  replay_lockstep(model, device, DeviceLimits{}, &session);
  session.close();
  const std::vector<double> flat = read_session_column(path, "/force_n");
  std::vector<Vec3d> forces(flat.size() / 3);
  for (std::size_t k = 0; k < forces.size(); ++k) {
    forces[k] = Vec3d(flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]);
  }
  return forces;
}

}  // namespace hapvox::haptics::bridge_testing
