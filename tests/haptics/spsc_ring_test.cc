#include "haptics/spsc_ring.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <thread>

namespace hapvox::haptics {
namespace {

TEST(SpscRing, HoldsExactlyItsCapacityAndGivesValuesBackInOrderAcrossTheWrap) {
  SpscRing<int, 8> ring;
  int value = -1;
  EXPECT_FALSE(ring.try_pop(value));
  EXPECT_EQ(value, -1);  // an empty pop leaves the target alone
  int next_in = 0, next_out = 0;
  // Three rounds of fill-to-full then drain-half walk the indices past the wrap.
  for (int round = 0; round < 3; ++round) {
    while (ring.try_push(next_in)) ++next_in;
    EXPECT_EQ(ring.was_size(), 8u);
    EXPECT_FALSE(ring.try_push(999));  // full: refused, nothing overwritten
    for (int i = 0; i < 4; ++i) {
      ASSERT_TRUE(ring.try_pop(value));
      EXPECT_EQ(value, next_out++);
    }
    EXPECT_EQ(ring.was_size(), 4u);
  }
  while (ring.try_pop(value)) EXPECT_EQ(value, next_out++);
  EXPECT_EQ(next_out, next_in);
  EXPECT_EQ(ring.was_size(), 0u);
}

// Under ThreadSanitizer this also checks that every slot's write happens before its read.
TEST(SpscRing, AProducerAndAConsumerThreadPassEveryValueOnceInOrder) {
  static SpscRing<std::uint64_t, 64> ring;  // small, so both sides find it full and empty
  constexpr std::uint64_t kCount = 200000;
  std::thread producer([&] {
    for (std::uint64_t v = 0; v < kCount;) {
      if (ring.try_push(v)) {
        ++v;
      } else {
        std::this_thread::yield();
      }
    }
  });
  std::uint64_t expected = 0, out_of_order = 0;
  while (expected < kCount) {
    std::uint64_t v = 0;
    if (!ring.try_pop(v)) {
      std::this_thread::yield();
      continue;
    }
    if (v != expected) ++out_of_order;
    expected = v + 1;
  }
  producer.join();
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(expected, kCount);
  std::uint64_t left = 0;
  EXPECT_FALSE(ring.try_pop(left));
}

}  // namespace
}  // namespace hapvox::haptics
