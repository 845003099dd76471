#include "haptics/render_feed.h"

#include <gtest/gtest.h>

#include <map>
#include <thread>

#include "engine/errors.h"
#include "engine/volume_io.h"
#include "haptics/clay_scene.h"
#include "haptics/realtime.h"
#include "haptics/voxel_model.h"
#include "render/gl_context.h"
#include "render/volume_renderer.h"

namespace hapvox::haptics {
namespace {

TEST(ToolStateMailbox, ReadsTheLatestStateAndNeverATornOne) {
  ToolStateMailbox mailbox;
  EXPECT_EQ(mailbox.read().tick, -1);
  mailbox.publish(RenderToolState{Vec3d(1, 2, 3), Vec3d(0, 0, -1), true, 7});
  const RenderToolState one = mailbox.read();
  EXPECT_EQ(one.center_mm, Vec3d(1, 2, 3));
  EXPECT_EQ(one.displacement_mm, Vec3d(0, 0, -1));
  EXPECT_TRUE(one.in_contact);
  EXPECT_EQ(one.tick, 7);
  // A writer at full speed; every state the reader sees is one the writer wrote whole.
  mailbox.publish(RenderToolState{Vec3d::Zero(), Vec3d::Zero(), true, 0});
  std::atomic<bool> stop{false};
  std::thread writer([&] {
    for (std::int64_t k = 0; !stop.load(std::memory_order_relaxed); ++k) {
      const double v = static_cast<double>(k);
      mailbox.publish(RenderToolState{Vec3d(v, v, v), Vec3d(-v, -v, -v), k % 2 == 0, k});
    }
  });
  std::int64_t last = -1;
  for (int i = 0; i < 200000; ++i) {
    const RenderToolState s = mailbox.read();
    const double v = static_cast<double>(s.tick);
    ASSERT_EQ(s.center_mm, Vec3d(v, v, v));
    ASSERT_EQ(s.displacement_mm, Vec3d(-v, -v, -v));
    ASSERT_EQ(s.in_contact, s.tick % 2 == 0);
    ASSERT_GE(s.tick, last);  // never older than what was already seen
    last = s.tick;
  }
  stop.store(true);
  writer.join();
}

TEST(VoxelPatchQueue, OverflowWaitsInTheBacklogAndEveryVoxelArrivesWithItsLatestDensity) {
  const engine::DensityField field = engine::generate_volume("block:dims=64");
  engine::MassGrid mass(field);
  VoxelPatchQueue queue;
  std::vector<openvdb::Coord> coords;
  for (int z = 0; z < 32; ++z) {
    for (int y = 0; y < 64; ++y) {
      for (int x = 0; x < 48; ++x) coords.emplace_back(x, y, z);
    }
  }
  ASSERT_GT(coords.size(), VoxelPatchQueue::kCapacity);
  queue.offer(coords, mass);
  EXPECT_FALSE(queue.drained_backlog());
  EXPECT_EQ(queue.full_events(), 1u);
  std::map<openvdb::Coord, int> seen;
  VoxelPatch patch;
  while (!queue.drained_backlog()) {
    while (queue.pop(patch)) {
      ++seen[patch.ijk];
      EXPECT_EQ(patch.density, mass.density(patch.ijk));
    }
    queue.offer({}, mass);
  }
  while (queue.pop(patch)) ++seen[patch.ijk];
  ASSERT_EQ(seen.size(), coords.size());
  for (const auto& [ijk, count] : seen) EXPECT_EQ(count, 1) << ijk;
}

// A realtime sculpting replay with a real render thread: the renderer keeps its own copy
// of the field from the feed and ends with the sculpted volume.
TEST(RenderFeed, RealtimeSculptingWithARenderThreadKeepsTheRenderersCopyExact) {
  fixtures::ClayScene scene;
  const engine::DensityField& field = scene.field;
  TraceDevice device = fixtures::clay_stroke_device(1000.0, 20.0);

  render::GlContext context;
  render::VolumeRenderer renderer(field, render::TransferFunction::from_spec("clay"));
  render::RenderSettings settings;
  settings.width = settings.height = 96;
  settings.mesh.slices = 64;
  const render::OrbitCamera camera =
      render::OrbitCamera::framing(field.world_min_mm(), field.world_max_mm(), 30.0, 40.0);
  context.release();
  std::int64_t frames_in_contact = 0;
  RealtimeOptions realtime;
  realtime.render_loop = [&](RenderFeed& feed, RenderTiming& timing) {
    context.make_current();
    VoxelPatch patch;
    while (true) {
      const bool finishing = feed.done.load(std::memory_order_acquire);
      while (feed.voxels.pop(patch)) {
        renderer.set_voxel(patch.ijk, patch.density);
        ++timing.voxels_applied;
      }
      const RenderToolState tool = feed.tool.read();
      render::ToolPose pose{tool.center_mm, tool.displacement_mm, 4.0, tool.in_contact};
      const auto begin = std::chrono::steady_clock::now();
      renderer.render(camera, pose, settings);
      timing.frame_start_ns.push_back(
          std::chrono::duration_cast<std::chrono::nanoseconds>(begin - feed.start).count());
      timing.frame_ns.push_back(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                    std::chrono::steady_clock::now() - begin)
                                    .count());
      timing.frame_tick.push_back(tool.tick);
      frames_in_contact += tool.in_contact;
      if (finishing) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    context.release();
  };
  SculptSummary sculpted;
  TimingSummary timing;
  replay_realtime(scene.model, device, DeviceLimits{}, nullptr, {}, &scene.sculpt, &sculpted,
                  &timing, realtime);
  context.make_current();
  EXPECT_EQ(sculpted.final_mass_units, sculpted.initial_mass_units);
  EXPECT_GT(sculpted.deleted_voxels, 0u);
  // Frames were drawn while the tool pressed, timed, and in tick order.
  ASSERT_GT(timing.render.frame_ns.size(), 10u);
  EXPECT_GT(frames_in_contact, 0);
  EXPECT_EQ(timing.render_frame.count, timing.render.frame_ns.size());
  EXPECT_GT(timing.render_fps, 0.0);
  for (std::size_t i = 1; i < timing.render.frame_tick.size(); ++i) {
    EXPECT_GE(timing.render.frame_tick[i], timing.render.frame_tick[i - 1]);
    EXPECT_GT(timing.render.frame_start_ns[i], timing.render.frame_start_ns[i - 1]);
  }
  EXPECT_GT(timing.render.voxels_applied, 0u);
  // The renderer's copy is the sculpted volume: it draws what a fresh upload draws.
  const engine::DensityField final_field = scene.mass.to_density_field();
  render::VolumeRenderer fresh(final_field, render::TransferFunction::from_spec("clay"));
  const render::Image ours = renderer.render(camera, render::ToolPose{}, settings);
  const render::Image reference = fresh.render(camera, render::ToolPose{}, settings);
  EXPECT_GT(render::psnr_db(ours, reference), 50.0);
}

}  // namespace
}  // namespace hapvox::haptics

namespace hapvox::haptics {
namespace {

// A 3 mm downward press above block:dims=32, at `speed_mm_s`.
TraceDevice press_into_block(double speed_mm_s) {
  TraceMakeOptions make;
  make.shape = TraceShape::kPress;
  make.start_mm = Vec3d(16, 16, 22);
  make.travel_mm = 3.0;
  make.speed_mm_s = speed_mm_s;
  return TraceDevice(resample(make_trace(make), ResampleOptions{}), DeviceTransform{});
}

// The overlay's loop line at the end of a run: the rate the loop ran at, not that of the
// last drain's span after it ended (which read 0.0 Hz in the window's last frame).
TEST(RenderFeed, TheLoopStatsAtTheEndShowTheRateTheLoopRanAt) {
  const engine::DensityField field = engine::generate_volume("block:dims=32");
  const engine::ToolForceModel model(field, engine::ToolForceOptions{});
  TraceDevice device = press_into_block(3.0);  // a second of ticks: several ~100 ms spans
  double end_rate_hz = -1.0;
  std::uint64_t end_ticks = 0;
  RealtimeOptions realtime;
  realtime.scheduler.lock_memory = false;
  realtime.render_loop = [&](RenderFeed& feed, RenderTiming&) {
    while (!feed.done.load(std::memory_order_acquire)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    end_rate_hz = feed.loop.rate_hz.load();
    end_ticks = feed.loop.ticks.load();
  };
  replay_realtime(model, device, DeviceLimits{}, nullptr, {}, nullptr, nullptr, nullptr, realtime);
  EXPECT_EQ(end_ticks, device.tick_count());
  // A 1 kHz loop, measured over ~100 ms spans: far from zero however loaded the machine.
  EXPECT_GT(end_rate_hz, 100.0);
}

TEST(RenderFeed, AFailingRenderLoopIsReportedAfterTheRealtimeRunNotACrash) {
  const engine::DensityField field = engine::generate_volume("block:dims=32");
  const engine::ToolForceModel model(field, engine::ToolForceOptions{});
  TraceDevice device = press_into_block(10.0);
  RealtimeOptions realtime;
  realtime.render_loop = [](RenderFeed&, RenderTiming&) {
    throw InputError("frames/frame_0000.png", "cannot be written");
  };
  TimingSummary timing;
  try {
    replay_realtime(model, device, DeviceLimits{}, nullptr, {}, nullptr, nullptr, &timing,
                    realtime);
    ADD_FAILURE() << "the render loop's error was lost";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "frames/frame_0000.png: cannot be written");
  }
}

}  // namespace
}  // namespace hapvox::haptics
