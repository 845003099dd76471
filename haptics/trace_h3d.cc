#include "haptics/trace_h3d.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "engine/errors.h"
#include "haptics/trace_raw.h"

namespace hapvox::haptics {
namespace {

struct Field {
  std::string_view name;
  int values;
};

// Every field HAPI::DeviceLog writes, with the numbers it writes for it.
constexpr std::array<Field, 13> kFields = {{{"TIME", 1},
                                            {"POSITION", 3},
                                            {"ORIENTATION", 4},
                                            {"VELOCITY", 3},
                                            {"FORCE", 3},
                                            {"TORQUE", 3},
                                            {"BUTTONS", 1},
                                            {"RAW_POSITION", 3},
                                            {"RAW_ORIENTATION", 4},
                                            {"RAW_VELOCITY", 3},
                                            {"RAW_FORCE", 3},
                                            {"RAW_TORQUE", 3},
                                            {"TIMESTAMP", 1}}};

const Field* find_field(std::string_view name) {
  for (const Field& f : kFields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

std::vector<std::string_view> split_spaces(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

std::string field_list() {
  std::string out;
  for (const Field& f : kFields) out += (out.empty() ? "" : ", ") + std::string(f.name);
  return out;
}

bool parse_number(std::string_view text, double* out) {
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, *out);
  return ec == std::errc() && ptr == end;
}

// A line of the text, without its newline (and a CR before it).
class Lines {
 public:
  explicit Lines(const std::string& text) : text_(text) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    std::size_t end = text_.find('\n', pos_);
    if (end == std::string::npos) end = text_.size();
    line = std::string_view(text_).substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = end + 1;
    ++number_;
    return true;
  }
  int number() const { return number_; }

 private:
  const std::string& text_;
  std::size_t pos_ = 0;
  int number_ = 0;
};

bool blank(std::string_view line) { return split_spaces(line).empty(); }

}  // namespace

bool is_h3d_device_log_header(std::string_view line) {
  const std::vector<std::string_view> names = split_spaces(line);
  if (names.empty()) return false;
  bool has_time = false;
  for (const std::string_view name : names) {
    if (find_field(name) == nullptr) return false;
    has_time = has_time || name == "TIME";
  }
  return has_time;
}

bool is_h3d_device_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  // The header is short; a binary log ends its header with a NUL, which ends the line.
  std::string line;
  while (std::getline(in, line, '\n')) {
    const std::size_t nul = line.find('\0');
    if (nul != std::string::npos) line.resize(nul);
    if (line.starts_with("\xEF\xBB\xBF")) line.erase(0, 3);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (blank(line)) continue;
    return is_h3d_device_log_header(line);
  }
  return false;
}

Trace parse_h3d_device_log(const std::string& text, const std::string& source) {
  if (text.find('\0') != std::string::npos) {
    throw InputError(source,
                     "a binary H3D DeviceLog (logBinary TRUE) is not read: log with logBinary "
                     "FALSE for a text log");
  }
  Lines lines(text);
  std::string_view line;
  while (lines.next(line) && blank(line)) {
  }
  if (!is_h3d_device_log_header(line)) {
    throw InputError(source, "line " + std::to_string(lines.number()) +
                                 ": not an H3D DeviceLog header (DeviceLog field names with "
                                 "TIME among them: " +
                                 field_list() + ")");
  }
  // Where each field's values start in a row.
  const std::vector<std::string_view> names = split_spaces(line);
  int width = 0;
  int time_at = -1, position_at = -1, raw_position_at = -1, orientation_at = -1,
      raw_orientation_at = -1;
  for (const std::string_view name : names) {
    if (name == "TIME") time_at = width;
    if (name == "POSITION") position_at = width;
    if (name == "RAW_POSITION") raw_position_at = width;
    if (name == "ORIENTATION") orientation_at = width;
    if (name == "RAW_ORIENTATION") raw_orientation_at = width;
    width += find_field(name)->values;
  }
  // The calibrated tracker values first (what the scene saw), else the device's own.
  const bool raw_pose = position_at < 0;
  const int pose_at = raw_pose ? raw_position_at : position_at;
  const int turn_at = raw_pose ? raw_orientation_at : orientation_at;
  if (pose_at < 0) {
    throw InputError(source, "line " + std::to_string(lines.number()) +
                                 ": the log holds no POSITION or RAW_POSITION");
  }
  const std::string position_name = raw_pose ? "RAW_POSITION" : "POSITION";

  detail::RawTrace raw;
  raw.kind = "field";
  std::vector<int> line_numbers;
  std::vector<double> values(static_cast<std::size_t>(width));
  while (lines.next(line)) {
    if (blank(line)) continue;
    const std::vector<std::string_view> tokens = split_spaces(line);
    const std::string where = "line " + std::to_string(lines.number());
    if (tokens.size() != values.size()) {
      throw InputError(source, where + ": expected " + std::to_string(width) +
                                   " numbers for the header's fields, found " +
                                   std::to_string(tokens.size()));
    }
    for (std::size_t i = 0; i < tokens.size(); ++i) {
      if (!parse_number(tokens[i], &values[i])) {
        throw InputError(source, where + ": not a number: '" + printable(tokens[i], 40) + "'");
      }
    }
    raw.time.push_back(values[time_at]);
    raw.position.push_back({values[pose_at], values[pose_at + 1], values[pose_at + 2]});
    if (turn_at >= 0) {
      // Axis and angle (radians) as a quaternion; the identity has a zero axis.
      const Vec3d axis(values[turn_at], values[turn_at + 1], values[turn_at + 2]);
      const double angle = values[turn_at + 3];
      const double length = axis.norm();
      if (!std::isfinite(length) || !std::isfinite(angle)) {
        throw InputError(source, where + ": orientation: NaN or infinite value");
      }
      if (!(length > 0.0) && angle != 0.0) {
        std::ostringstream turn;
        turn << angle;
        throw InputError(source,
                         where + ": orientation turns by " + turn.str() + " rad about a zero axis");
      }
      const double half = 0.5 * angle;
      const Vec3d v = length > 0.0 ? Vec3d(axis / length * std::sin(half)) : Vec3d::Zero();
      raw.orientation.push_back({std::cos(half), v.x(), v.y(), v.z()});
    }
    line_numbers.push_back(lines.number());
  }
  raw.where = [&](std::size_t i) { return "line " + std::to_string(line_numbers[i]); };
  // HAPI logs seconds and metres.
  TraceColumns units;
  units.time = "TIME";
  units.position = {position_name + " x", position_name + " y", position_name + " z"};
  units.orientation = {"ORIENTATION", "ORIENTATION", "ORIENTATION", "ORIENTATION"};
  units.mm_per_position_unit = 1000.0;
  return detail::finish_trace(source, units, raw);
}

Trace read_h3d_device_log(const std::string& path) {
  return parse_h3d_device_log(detail::read_trace_text(path), path);
}

}  // namespace hapvox::haptics
