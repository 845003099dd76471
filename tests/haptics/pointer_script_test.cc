#include "haptics/pointer_script.h"

#include <gtest/gtest.h>

#include "engine/errors.h"

namespace hapvox::haptics {
namespace {

TEST(PointerScript, EveryEventReadsBack) {
  const std::vector<PointerEvent> events = parse_pointer_script(
      "# a groove\n"
      "\n"
      "0.5 move 320 240\n"
      "0.6\tmove 400.5 240 1.5   # dragging\n"
      "0.7 press\n"
      "0.7 wheel -2\n"
      "1.2 key space down\n"
      "1.3 key space up\n"
      "2.4 release\r\n"
      "2.5 screenshot out/groove.png\n"
      "3 quit\n",
      "s.txt");
  ASSERT_EQ(events.size(), 9u);
  using K = PointerEvent::Kind;
  EXPECT_EQ(events[0].kind, K::kMove);
  EXPECT_EQ(events[0].time_s, 0.5);
  EXPECT_EQ(events[0].x_px, 320.0);
  EXPECT_EQ(events[0].y_px, 240.0);
  EXPECT_EQ(events[0].over_s, 0.0);
  EXPECT_EQ(events[1].x_px, 400.5);
  EXPECT_EQ(events[1].over_s, 1.5);
  EXPECT_EQ(events[2].kind, K::kPress);
  EXPECT_EQ(events[3].kind, K::kWheel);
  EXPECT_EQ(events[3].wheel_steps, -2.0);
  EXPECT_EQ(events[4].kind, K::kKeyDown);
  EXPECT_EQ(events[4].key, "space");
  EXPECT_EQ(events[5].kind, K::kKeyUp);
  EXPECT_EQ(events[6].kind, K::kRelease);
  EXPECT_EQ(events[7].kind, K::kScreenshot);
  EXPECT_EQ(events[7].path, "out/groove.png");
  EXPECT_EQ(events[8].kind, K::kQuit);
  EXPECT_EQ(events[8].time_s, 3.0);
}

std::string error_of(const std::string& text) {
  try {
    parse_pointer_script(text, "s.txt");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(PointerScript, EachBadLineIsNamedWithItsProblem) {
  EXPECT_EQ(error_of("0 press\nsoon press\n"), "s.txt:2: the time 'soon' is not a number");
  EXPECT_EQ(error_of("1 press\n0.5 release\n"),
            "s.txt:2: the time goes back (events must be in time order)");
  EXPECT_EQ(error_of("-1 press\n"), "s.txt:1: the time must not be negative");
  EXPECT_EQ(error_of("inf press\n"), "s.txt:1: the time 'inf' is not a number");
  EXPECT_EQ(error_of("1\n"), "s.txt:1: expected 'TIME_S EVENT ...'");
  EXPECT_EQ(error_of("1 click\n"),
            "s.txt:1: unknown event 'click' (move, press, release, wheel, key, screenshot, quit)");
  EXPECT_EQ(error_of("1 move 3\n"), "s.txt:1: 'move' takes PX PY [OVER_S]");
  EXPECT_EQ(error_of("1 move 3 4 -1\n"), "s.txt:1: the duration must not be negative");
  EXPECT_EQ(error_of("1 move 3 nan\n"), "s.txt:1: the row 'nan' is not a number");
  EXPECT_EQ(error_of("1 press now\n"), "s.txt:1: 'press' takes nothing");
  EXPECT_EQ(error_of("1 key ctrl down\n"),
            "s.txt:1: unknown key 'ctrl' (space, up, down, left, right, escape, [, ], p, z)");
  EXPECT_EQ(error_of("1 key space held\n"), "s.txt:1: a key goes 'down' or 'up', not 'held'");
  EXPECT_EQ(error_of("1 screenshot shot.jpg\n"), "s.txt:1: a screenshot is a .png, not 'shot.jpg'");
  EXPECT_EQ(error_of("1 wheel \x01\n"), "s.txt:1: the steps '\\x01' is not a number");
}

TEST(PointerScript, AMissingFileIsNamed) {
  EXPECT_THROW(read_pointer_script("/nonexistent/script.txt"), InputError);
}

}  // namespace
}  // namespace hapvox::haptics
