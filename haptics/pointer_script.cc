#include "haptics/pointer_script.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

#include "engine/errors.h"
#include "engine/text_file.h"

namespace hapvox::haptics {
namespace {

std::vector<std::string> words_of(const std::string& line) {
  std::vector<std::string> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= line.size() || line[i] == '#') break;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

double number(const std::string& word, const char* what, const std::string& where) {
  double value = 0.0;
  const char* end = word.data() + word.size();
  const auto [ptr, ec] = std::from_chars(word.data(), end, value);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) {
    throw InputError(where, std::string(what) + " '" + printable(word, 40) + "' is not a number");
  }
  return value;
}

}  // namespace

const std::vector<std::string>& pointer_script_keys() {
  static const std::vector<std::string> keys = {"space", "up", "down", "left", "right", "escape",
                                                "[",     "]",  "p",    "z",    "m"};
  return keys;
}

std::vector<PointerEvent> parse_pointer_script(const std::string& text, const std::string& source) {
  std::vector<PointerEvent> events;
  std::istringstream lines(text);
  std::string line;
  int line_number = 0;
  double last_time_s = 0.0;
  while (std::getline(lines, line)) {
    ++line_number;
    const std::vector<std::string> w = words_of(line);
    if (w.empty()) continue;
    const std::string where = source + ":" + std::to_string(line_number);
    if (w.size() < 2) throw InputError(where, "expected 'TIME_S EVENT ...'");
    PointerEvent e;
    e.time_s = number(w[0], "the time", where);
    if (e.time_s < 0.0) throw InputError(where, "the time must not be negative");
    if (e.time_s < last_time_s) {
      throw InputError(where, "the time goes back (events must be in time order)");
    }
    last_time_s = e.time_s;
    const std::string& event = w[1];
    auto expect_args = [&](std::size_t lo, std::size_t hi, const char* usage) {
      if (w.size() - 2 < lo || w.size() - 2 > hi) {
        throw InputError(where, "'" + event + "' takes " + usage);
      }
    };
    if (event == "move") {
      expect_args(2, 3, "PX PY [OVER_S]");
      e.kind = PointerEvent::Kind::kMove;
      e.x_px = number(w[2], "the column", where);
      e.y_px = number(w[3], "the row", where);
      if (w.size() == 5) e.over_s = number(w[4], "the duration", where);
      if (e.over_s < 0.0) throw InputError(where, "the duration must not be negative");
    } else if (event == "press" || event == "release" || event == "quit") {
      expect_args(0, 0, "nothing");
      e.kind = event == "press"     ? PointerEvent::Kind::kPress
               : event == "release" ? PointerEvent::Kind::kRelease
                                    : PointerEvent::Kind::kQuit;
    } else if (event == "wheel") {
      expect_args(1, 1, "STEPS");
      e.kind = PointerEvent::Kind::kWheel;
      e.wheel_steps = number(w[2], "the steps", where);
    } else if (event == "key") {
      expect_args(2, 2, "NAME down|up");
      const auto& keys = pointer_script_keys();
      if (std::find(keys.begin(), keys.end(), w[2]) == keys.end()) {
        throw InputError(where, "unknown key '" + printable(w[2], 40) +
                                    "' (space, up, down, left, right, escape, [, ], p, z)");
      }
      if (w[3] != "down" && w[3] != "up") {
        throw InputError(where, "a key goes 'down' or 'up', not '" + printable(w[3], 40) + "'");
      }
      e.kind = w[3] == "down" ? PointerEvent::Kind::kKeyDown : PointerEvent::Kind::kKeyUp;
      e.key = w[2];
    } else if (event == "screenshot") {
      expect_args(1, 1, "PATH.png");
      const std::string& path = w[2];
      if (path.size() < 5 || path.substr(path.size() - 4) != ".png") {
        throw InputError(where, "a screenshot is a .png, not '" + printable(path, 40) + "'");
      }
      e.kind = PointerEvent::Kind::kScreenshot;
      e.path = path;
    } else {
      throw InputError(where, "unknown event '" + printable(event, 40) +
                                  "' (move, press, release, wheel, key, screenshot, quit)");
    }
    events.push_back(std::move(e));
  }
  return events;
}

std::vector<PointerEvent> read_pointer_script(const std::string& path) {
  return parse_pointer_script(engine::read_text_file(path), path);
}

}  // namespace hapvox::haptics
