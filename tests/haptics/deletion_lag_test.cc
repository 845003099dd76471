#include "haptics/deletion_lag.h"

#include <gtest/gtest.h>

#include <vector>

#include "engine/volume_io.h"
#include "haptics/trace_device.h"
#include "haptics/voxel_model.h"

namespace hapvox::haptics {
namespace {

// Ticks 1 ms apart, each read at k ms and sent 0.2 ms later; events at ticks 1, 2 and 5,
// whose field reads them `seen_after` ticks later.
std::vector<TickTimes> ticks_with_events(int seen_after, int count) {
  std::vector<TickTimes> ticks(count);
  const std::vector<int> event_ticks = {1, 2, 5};
  for (int k = 0; k < count; ++k) {
    ticks[k].read_ns = k * 1'000'000LL;
    ticks[k].sent_ns = ticks[k].read_ns + 200'000;
  }
  for (int e = 0; e < 3; ++e) {
    ticks[event_ticks[e]].plastic_event = true;
    for (int k = event_ticks[e] + seen_after; k < count; ++k) ticks[k].published_event = e;
  }
  return ticks;
}

// Each event's lag runs from its tick's send to the read of the first tick whose field has
// it: (seen_after - 0.2) ms. An event no later tick read counts as unseen, not as a lag.
TEST(DeletionLag, RunsFromTheEventsSendToTheFirstTickThatReadsItsDeletion) {
  const DeletionLags next = deletion_lags(ticks_with_events(1, 10));
  EXPECT_EQ(next.events, 3u);
  EXPECT_EQ(next.unseen, 0u);
  EXPECT_DOUBLE_EQ(next.p50_ms, 0.8);
  EXPECT_DOUBLE_EQ(next.max_ms, 0.8);
  EXPECT_EQ(next.p99_ticks, 1.0);

  const DeletionLags late = deletion_lags(ticks_with_events(3, 10));
  EXPECT_EQ(late.unseen, 0u);
  EXPECT_DOUBLE_EQ(late.p99_ms, 2.8);
  EXPECT_EQ(late.p99_ticks, 3.0);

  // Cut short at tick 7: event 2 (tick 5) would be read at tick 8.
  const DeletionLags cut = deletion_lags(ticks_with_events(3, 8));
  EXPECT_EQ(cut.events, 3u);
  EXPECT_EQ(cut.unseen, 1u);
  EXPECT_DOUBLE_EQ(cut.max_ms, 2.8);
}

// Records each tick's plastic numbers as the force loop sends them.
class EventRecorder final : public Device {
 public:
  explicit EventRecorder(Device& inner) : inner_(inner) {}
  double rate_hz() const override { return inner_.rate_hz(); }
  std::size_t tick_count() const override { return inner_.tick_count(); }
  const DeviceTransform& transform() const override { return inner_.transform(); }
  void read(std::size_t tick, DeviceReading& reading) override { inner_.read(tick, reading); }
  void send(std::size_t, const Vec3d&, const TickRecord& row, bool) override {
    TickTimes t;
    t.plastic_event = row.plastic_event != 0;
    t.published_event = row.published_event;
    ticks.push_back(t);
  }
  std::vector<TickTimes> ticks;

 private:
  Device& inner_;
};

// In lockstep a tick's deletion is applied and published before the next tick: the force
// stage numbers its events 0, 1, 2, ... and every tick reads a field that has every event
// before it, and none of its own.
TEST(DeletionLag, InLockstepEveryTickReadsTheDeletionsOfAllTicksBeforeIt) {
  engine::DensityField field = engine::generate_volume("block:dims=48");  // face z = 23.5
  engine::ToolForceOptions options;
  options.tool.diameter_mm = 8.0;
  options.plastic.enabled = true;
  const engine::ToolForceModel model(field, options);
  engine::MassGrid mass(field);
  SurfaceChangeChannel channel;
  SculptContext context;
  context.mass = &mass;
  context.mirror = &field;
  context.channel = &channel;
  TraceMakeOptions make;
  make.shape = TraceShape::kStroke;
  make.start_mm = Vec3d(14.3, 24.1, 29.0);
  make.travel_mm = 7.0;  // tool bottom 2.5 mm below the face
  make.speed_mm_s = 20.0;
  make.stroke_length_mm = 12.0;
  TraceDevice trace(resample(make_trace(make)), DeviceTransform{});
  EventRecorder device(trace);
  replay_lockstep(model, device, DeviceLimits{}, nullptr, {}, &context);

  std::int64_t events = 0;
  for (const TickTimes& t : device.ticks) {
    ASSERT_EQ(t.published_event, events - 1);
    events += t.plastic_event ? 1 : 0;
  }
  EXPECT_GT(events, 500);
  const DeletionLags lags = deletion_lags(device.ticks);
  EXPECT_EQ(lags.events, static_cast<std::size_t>(events));
  EXPECT_EQ(lags.p99_ticks, 1.0);
}

}  // namespace
}  // namespace hapvox::haptics
