// Sequence numbers through loss, reordering, duplicates and wrap-around.

#include "haptics/bridge_sequence.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

namespace hapvox::haptics {
namespace {

TEST(SequenceWindow, InOrderIsAllFresh) {
  SequenceWindow w;
  for (std::uint32_t s = 10; s < 110; ++s) EXPECT_EQ(w.arrive(s), Arrival::fresh);
  EXPECT_EQ(w.received(), 100u);
  EXPECT_EQ(w.fresh(), 100u);
  EXPECT_EQ(w.lost(), 0u);
  EXPECT_EQ(w.late(), 0u);
  EXPECT_EQ(w.duplicates(), 0u);
  EXPECT_EQ(w.newest(), 109u);
}

TEST(SequenceWindow, AGapIsLostUntilItsPacketComesLate) {
  SequenceWindow w;
  for (std::uint32_t s : {0u, 1u, 3u, 4u}) EXPECT_EQ(w.arrive(s), Arrival::fresh);
  EXPECT_EQ(w.lost(), 1u);
  EXPECT_EQ(w.arrive(2), Arrival::late);
  EXPECT_EQ(w.lost(), 0u);
  EXPECT_EQ(w.late(), 1u);
  EXPECT_EQ(w.arrive(2), Arrival::duplicate);
  EXPECT_EQ(w.arrive(4), Arrival::duplicate);
  EXPECT_EQ(w.duplicates(), 2u);
  EXPECT_EQ(w.received(), 7u);
}

TEST(SequenceWindow, NumbersWrapAround) {
  SequenceWindow w;
  for (std::uint32_t s : {0xFFFFFFFEu, 0xFFFFFFFFu, 0u, 2u}) EXPECT_EQ(w.arrive(s), Arrival::fresh);
  EXPECT_EQ(w.lost(), 1u);
  EXPECT_EQ(w.arrive(1u), Arrival::late);
  EXPECT_EQ(w.arrive(0xFFFFFFFFu), Arrival::duplicate);
  EXPECT_EQ(w.lost(), 0u);
  EXPECT_EQ(w.newest(), 2u);
}

TEST(SequenceWindow, OlderThanTheWindowIsLateAndStaysLost) {
  SequenceWindow w;
  w.arrive(0);
  w.arrive(100);
  EXPECT_EQ(w.lost(), 99u);
  EXPECT_EQ(w.arrive(50), Arrival::late);  // 50 behind: inside the window
  EXPECT_EQ(w.lost(), 98u);
  EXPECT_EQ(w.arrive(50), Arrival::duplicate);
  EXPECT_EQ(w.arrive(20), Arrival::late);  // 80 behind: outside, not remembered
  EXPECT_EQ(w.lost(), 98u);
  EXPECT_EQ(w.arrive(0), Arrival::late);  // a duplicate, but too old to know
  EXPECT_EQ(w.duplicates(), 1u);
}

// The defect of issue 27: one packet numbered 2^31 - 10 ahead was taken as fresh, so the
// device's own next packets (now "older") all counted as late and the jump as 2^31 losses.
// Out of the window it is refused, and the stream goes on as if it had never come.
TEST(SequenceWindow, AForgedJumpIsRefusedAndTheStreamGoesOn) {
  SequenceWindow w;
  for (std::uint32_t s = 0; s < 100; ++s) ASSERT_EQ(w.arrive(s), Arrival::fresh);
  EXPECT_NE(w.arrive(99u + (1u << 31) - 10u), Arrival::fresh);
  EXPECT_NE(w.arrive(99u + (1u << 30)), Arrival::fresh);
  EXPECT_NE(w.arrive(99u + kSequenceMaxJump + 1u), Arrival::fresh);
  EXPECT_EQ(w.newest(), 99u);
  for (std::uint32_t s = 100; s < 700; ++s) ASSERT_EQ(w.arrive(s), Arrival::fresh) << s;
  EXPECT_EQ(w.late(), 0u);
  EXPECT_EQ(w.lost(), 0u);
  EXPECT_EQ(w.duplicates(), 0u);
  EXPECT_EQ(w.out_of_window(), 3u);
  EXPECT_EQ(w.fresh(), 700u);
  EXPECT_EQ(w.received(), 703u);
}

// The window's edges: max_jump ahead is fresh (its gap lost), one more is not; the caller's
// allowance widens it (a device that kept counting through a silence); further behind than
// max_jump is refused too, not counted late.
TEST(SequenceWindow, TheWindowsEdgesAndTheAllowance) {
  SequenceWindow w(100);
  EXPECT_EQ(w.max_jump(), 100u);
  w.arrive(1000);
  EXPECT_EQ(w.arrive(1101), Arrival::out_of_window);
  EXPECT_EQ(w.arrive(1100), Arrival::fresh);
  EXPECT_EQ(w.lost(), 99u);
  EXPECT_EQ(w.arrive(1100 + 350), Arrival::out_of_window);
  EXPECT_EQ(w.arrive(1100 + 350, 250), Arrival::fresh);  // 100 + 250 allowed
  EXPECT_EQ(w.lost(), 99u + 349u);
  EXPECT_EQ(w.arrive(1450 - 101), Arrival::out_of_window);  // too far behind
  EXPECT_EQ(w.arrive(1450 - 100), Arrival::late);
  EXPECT_EQ(w.arrive(1450 + 0xFFFFFFFFu), Arrival::late);  // 1 behind, through the wrap
  EXPECT_EQ(w.out_of_window(), 3u);
  EXPECT_EQ(w.late(), 2u);
  // No allowance takes a jump past 2^30 (kSequenceJumpCeiling).
  EXPECT_EQ(w.arrive(1450u + (1u << 31) - 10u, 0xFFFFFFFFu), Arrival::out_of_window);
  EXPECT_EQ(w.arrive(1450u + (1u << 30) + 1u, 0xFFFFFFFFu), Arrival::out_of_window);
  EXPECT_EQ(w.newest(), 1450u);
  EXPECT_EQ(w.arrive(1450u + (1u << 30), 0xFFFFFFFFu), Arrival::fresh);
}

// A stream with 5 % dropped, 1 % delayed by a few packets and 0.5 % duplicated: every count
// matches what was done to it.
TEST(SequenceWindow, CountsWhatALossyNetworkDid) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::uint32_t> sent;
  for (std::uint32_t s = 0; s < 100000; ++s) sent.push_back(s);
  std::vector<std::uint32_t> wire;
  std::set<std::uint32_t> dropped, delayed;
  std::size_t duplicated = 0;
  std::vector<std::pair<std::size_t, std::uint32_t>> held;  // (release after index, seq)
  bool next_through = false;  // the packet after a delayed one passes it
  for (std::size_t i = 0; i < sent.size(); ++i) {
    const std::uint32_t s = sent[i];
    const double r = u(rng);
    // The first and last 100 go straight through, so every gap is closed by a later packet.
    const bool may_fail = i > 100 && i + 100 < sent.size() && !next_through;
    next_through = false;
    if (may_fail && r < 0.05) {
      dropped.insert(s);
    } else if (may_fail && r < 0.06) {
      delayed.insert(s);
      next_through = true;
      held.push_back({i + 1 + static_cast<std::size_t>(u(rng) * 20), s});
    } else {
      wire.push_back(s);
      if (r > 0.995) {
        wire.push_back(s);
        ++duplicated;
      }
    }
    for (auto it = held.begin(); it != held.end();) {
      if (it->first == i) {
        wire.push_back(it->second);
        it = held.erase(it);
      } else {
        ++it;
      }
    }
  }
  ASSERT_TRUE(held.empty());
  SequenceWindow w;
  for (std::uint32_t s : wire) w.arrive(s);
  EXPECT_EQ(w.received(), wire.size());
  EXPECT_EQ(w.lost(), dropped.size());
  EXPECT_EQ(w.late(), delayed.size());
  EXPECT_EQ(w.duplicates(), duplicated);
  EXPECT_EQ(w.fresh(), sent.size() - dropped.size() - delayed.size());
  EXPECT_GT(dropped.size(), 4000u);
  EXPECT_GT(delayed.size(), 800u);
}

}  // namespace
}  // namespace hapvox::haptics
