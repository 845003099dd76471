#include "haptics/double_buffered_field.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "engine/volume_io.h"

namespace hapvox::haptics {
namespace {

// The tool's sphere (3 mm) at `at_mm`, pushing down.
engine::SurfaceChange cut_at(const Vec3d& at_mm) {
  engine::SurfaceChange cut;
  cut.from_mm = cut.position_mm = at_mm;
  cut.direction = Vec3d(0, 0, -1);
  cut.radius_mm = 3.0;
  return cut;
}

// The writer never writes the buffer the reader holds: a publication writes the back
// buffer and flips, and the next one (which must write the old front) waits until the
// reader has announced the new front. A writer that did not wait would change buffer 0
// under the reader (and return at once); one that waited after each flip, as before,
// would hang in the first publication, the reader never reading again.
TEST(DoubleBufferedField, APublicationWaitsForTheReaderToLeaveTheBufferItWrites) {
  const engine::DensityField field = engine::generate_volume("block:dims=24,fill=1");
  DoubleBufferedField buffers(field);
  engine::MassGrid mass(field);
  const std::atomic<bool> reader_done{false};
  const Vec3d first(8.0, 12.0, 12.0), second(16.0, 12.0, 12.0);
  ASSERT_EQ(buffers.buffer(0).sample_world(first), 1.0);

  ASSERT_EQ(buffers.acquire_for_reading(), 0);  // the reader holds buffer 0
  mass.apply_deletion(cut_at(first));
  buffers.publish(mass, reader_done);  // writes buffer 1: no wait
  EXPECT_EQ(buffers.front(), 1);
  EXPECT_EQ(buffers.buffer(1).sample_world(first), 0.0);
  EXPECT_EQ(buffers.buffer(0).sample_world(first), 1.0);  // not under the reader

  mass.apply_deletion(cut_at(second));
  std::atomic<bool> returned{false};
  std::thread writer([&] {
    buffers.publish(mass, reader_done);  // must write buffer 0, still held
    returned.store(true);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(returned.load());
  EXPECT_EQ(buffers.buffer(0).sample_world(first), 1.0);
  EXPECT_EQ(buffers.buffer(0).sample_world(second), 1.0);
  EXPECT_EQ(buffers.acquire_for_reading(), 1);  // the reader moves to the new front
  writer.join();
  EXPECT_TRUE(returned.load());
  EXPECT_EQ(buffers.front(), 0);
  // Buffer 0 got both cuts (the one it was owed and the new one); buffer 1 owes the second.
  EXPECT_EQ(buffers.buffer(0).sample_world(first), 0.0);
  EXPECT_EQ(buffers.buffer(0).sample_world(second), 0.0);
  EXPECT_EQ(buffers.buffer(1).sample_world(second), 1.0);
}

// A publication's event number travels with the buffer it made the front: the reader sees
// the number of the buffer it acquired, never a newer one for an older buffer. With nothing
// to write, both buffers match the grid and both take the number.
TEST(DoubleBufferedField, TheEventNumberTravelsWithTheBufferItStamps) {
  const engine::DensityField field = engine::generate_volume("block:dims=24,fill=1");
  DoubleBufferedField buffers(field);
  engine::MassGrid mass(field);
  const std::atomic<bool> reader_done{false};
  EXPECT_EQ(buffers.published_event(buffers.acquire_for_reading()), -1);

  mass.apply_deletion(cut_at(Vec3d(8.0, 12.0, 12.0)));
  buffers.publish(mass, reader_done, nullptr, 4);  // writes buffer 1
  EXPECT_EQ(buffers.published_event(0), -1);       // the old front has not taken it in
  const int front = buffers.acquire_for_reading();
  EXPECT_EQ(front, 1);
  EXPECT_EQ(buffers.published_event(front), 4);

  mass.apply_deletion(cut_at(Vec3d(16.0, 12.0, 12.0)));
  buffers.publish(mass, reader_done, nullptr, 9);  // writes buffer 0 (owed event 4's cut too)
  EXPECT_EQ(buffers.published_event(1), 4);
  EXPECT_EQ(buffers.published_event(buffers.acquire_for_reading()), 9);

  // With no new change, buffer 1 still owes the second cut: written, stamped and flipped.
  EXPECT_GT(buffers.publish(mass, reader_done, nullptr, 10), 0u);
  EXPECT_EQ(buffers.front(), 1);
  EXPECT_EQ(buffers.published_event(buffers.acquire_for_reading()), 10);
  // Now both buffers match the grid: an event that changed nothing stamps both, no flip.
  EXPECT_EQ(buffers.publish(mass, reader_done, nullptr, 11), 0u);
  EXPECT_EQ(buffers.front(), 1);
  EXPECT_EQ(buffers.published_event(0), 11);
  EXPECT_EQ(buffers.published_event(1), 11);
}

}  // namespace
}  // namespace hapvox::haptics
