#pragma once
// Scripted pointer input for a sculpting window (`hapvox sculpt --script FILE`): what a
// person's mouse and keys would do, with times, so a window can be driven the same way
// every time (under Xvfb in CI, in a demo). One event per line (docs/formats.md):
//
//   # comment
//   0.5  move 320 240          the cursor to pixel (320, 240) (column, row; 0 at the top)
//   0.6  move 400 240 1.5      ... in a straight line over the next 1.5 s
//   0.7  press                 the left button down: picks the surface under the cursor
//   2.4  release
//   1.0  wheel -2              two notches: + pushes the tool in, - pulls it out
//   1.2  key space down        a key down or up: space, up, down, left, right, escape, and
//                              [ ] (tool size), p (plastic), z (undo), m (model)
//   2.5  screenshot groove.png the window as it is drawn then, as a PNG
//   3.0  quit                  ends the session, as closing the window does
//
// Times are seconds from the window's first frame and never decrease; the clock stops while
// a key that changes the tool or the clay starts the session's next segment.

#include <string>
#include <vector>

namespace hapvox::haptics {

struct PointerEvent {
  enum class Kind { kMove, kPress, kRelease, kWheel, kKeyDown, kKeyUp, kScreenshot, kQuit };
  double time_s = 0.0;
  Kind kind = Kind::kQuit;
  double x_px = 0.0, y_px = 0.0;  // kMove: the cursor's destination
  double over_s = 0.0;            // kMove: how long it takes to get there (0: at once)
  double wheel_steps = 0.0;       // kWheel
  std::string key;                // kKeyDown, kKeyUp: one of pointer_script_keys()
  std::string path;               // kScreenshot: a .png
};

/// The key names a script may use.
const std::vector<std::string>& pointer_script_keys();

/// Parses a script's text. Throws InputError("SOURCE:LINE", problem) for a line that is not
/// an event, a time that goes back, a number that is not finite, an unknown key.
std::vector<PointerEvent> parse_pointer_script(const std::string& text, const std::string& source);

/// Reads and parses the script at `path` (InputError naming the path).
std::vector<PointerEvent> read_pointer_script(const std::string& path);

}  // namespace hapvox::haptics
