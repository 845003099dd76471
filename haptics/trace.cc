#include "haptics/trace.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/input_limits.h"
#include "engine/io/output_file.h"
#include "haptics/trace_h3d.h"
#include "haptics/trace_raw.h"

namespace hapvox::haptics {
namespace detail {

// Shortest text that round-trips, so messages show "0.5" rather than "0.50000000000000000".
std::string format_double(double v) {
  char buf[64];
  const auto result = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, result.ptr);
}

void check_trace_shape(const Trace& trace, const std::string& source) {
  if (trace.time_s.size() != trace.position_mm.size()) {
    throw InputError(source, "trace has " + std::to_string(trace.time_s.size()) + " times but " +
                                 std::to_string(trace.position_mm.size()) + " positions");
  }
  if (!trace.orientation.empty() && trace.orientation.size() != trace.time_s.size()) {
    throw InputError(source, "trace has " + std::to_string(trace.time_s.size()) + " times but " +
                                 std::to_string(trace.orientation.size()) + " orientations");
  }
}

void check_scales(const std::string& source, const TraceColumns& columns) {
  if (!(columns.seconds_per_time_unit > 0.0) || !std::isfinite(columns.seconds_per_time_unit)) {
    throw InputError(source, "time scale must be positive and finite (got " +
                                 format_double(columns.seconds_per_time_unit) + ")");
  }
  if (!(columns.mm_per_position_unit > 0.0) || !std::isfinite(columns.mm_per_position_unit)) {
    throw InputError(source, "position scale must be positive and finite (got " +
                                 format_double(columns.mm_per_position_unit) + ")");
  }
}

}  // namespace detail

namespace {

using detail::check_scales;
using detail::check_trace_shape;
using detail::format_double;

// Caps on generated sample counts, so a typo in a rate cannot exhaust memory.
constexpr double kMaxTicks = 1e9;

std::string_view trim(std::string_view s) {
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

// Strict number parse: the whole (trimmed) field must be a number. A leading '+' is
// accepted because spreadsheets write it; from_chars does not.
bool parse_double(std::string_view field, double* out) {
  std::string_view s = trim(field);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto result = std::from_chars(s.data(), s.data() + s.size(), *out);
  return result.ec == std::errc() && result.ptr == s.data() + s.size();
}

// Splits one CSV line on commas, honouring double quotes ("" is a literal quote inside a
// quoted field). Fields are trimmed, and quotes removed.
std::vector<std::string> split_csv_line(std::string_view line) {
  std::vector<std::string> fields;
  std::string field;
  bool in_quotes = false;
  bool was_quoted = false;
  const auto finish = [&] {
    fields.push_back(was_quoted ? field : std::string(trim(field)));
    field.clear();
    was_quoted = false;
  };
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (in_quotes) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          field += '"';
          ++i;
        } else {
          in_quotes = false;
        }
      } else {
        field += c;
      }
    } else if (c == '"' && trim(field).empty()) {
      field.clear();  // drop spaces before the opening quote
      in_quotes = true;
      was_quoted = true;
    } else if (c == ',') {
      finish();
    } else if (!(was_quoted && (c == ' ' || c == '\t'))) {
      field += c;  // spaces after a closing quote are dropped
    }
  }
  finish();
  return fields;
}

// A header that names a column twice would leave which one is read to the order of a search.
void check_unique_columns(const std::vector<std::string>& names, const std::string& path) {
  std::unordered_map<std::string_view, std::size_t> first;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i].empty()) continue;
    const auto [at, added] = first.emplace(names[i], i);
    if (!added) {
      throw InputError(
          path, "column '" + printable(names[i], 40) + "' appears twice in the header (columns " +
                    std::to_string(at->second + 1) + " and " + std::to_string(i + 1) + ")");
    }
  }
}

bool is_skipped_line(std::string_view line) {
  const std::string_view t = trim(line);
  return t.empty() || t.front() == '#';
}

bool has_h5_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".h5" || ext == ".hdf5";
}

// --- make_trace -----------------------------------------------------------------------

// One constant-speed piece of a synthetic path; at(u) for u in [0, 1].
struct Piece {
  double duration_s;
  std::function<Vec3d(double)> at;
};

Piece line_piece(const Vec3d& a, const Vec3d& b, double speed) {
  return {(b - a).norm() / speed, [a, b](double u) { return Vec3d(a + u * (b - a)); }};
}

Piece hold_piece(const Vec3d& p, double duration_s) {
  return {duration_s, [p](double) { return p; }};
}

void require(bool ok, const std::string& problem) {
  if (!ok) throw InputError("trace make", problem);
}

bool finite(const Vec3d& v) { return v.allFinite(); }

}  // namespace

using detail::finish_trace;
using detail::RawTrace;

namespace detail {

Trace finish_trace(const std::string& source, const TraceColumns& columns, const RawTrace& raw) {
  const std::size_t n = raw.time.size();
  HAPVOX_CHECK_EQ(n, raw.position.size());
  HAPVOX_CHECK(raw.orientation.empty() || raw.orientation.size() == n);
  const auto not_finite = [&](std::size_t i, const std::string& name, bool scaled) {
    return InputError(source, raw.where(i) + ": " + raw.kind + " '" + name +
                                  "': NaN or infinite value" +
                                  (scaled ? " after unit scaling" : ""));
  };
  Trace trace;
  trace.time_s.reserve(n);
  trace.position_mm.reserve(n);
  trace.orientation.reserve(raw.orientation.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(raw.time[i])) throw not_finite(i, columns.time, false);
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(raw.position[i][a])) throw not_finite(i, columns.position[a], false);
    }
    const double t = raw.time[i] * columns.seconds_per_time_unit;
    const Vec3d p = Vec3d(raw.position[i][0], raw.position[i][1], raw.position[i][2]) *
                    columns.mm_per_position_unit;
    if (!std::isfinite(t)) throw not_finite(i, columns.time, true);
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(p[a])) throw not_finite(i, columns.position[a], true);
    }
    if (i > 0 && !(t > trace.time_s.back())) {
      throw InputError(source, raw.where(i) + ": time " + format_double(raw.time[i]) +
                                   " does not increase (previous " +
                                   format_double(raw.time[i - 1]) + ")");
    }
    trace.time_s.push_back(t);
    trace.position_mm.push_back(p);
    if (!raw.orientation.empty()) {
      const auto& q = raw.orientation[i];
      for (int c = 0; c < 4; ++c) {
        if (!std::isfinite(q[c])) throw not_finite(i, columns.orientation[c], false);
      }
      Eigen::Quaterniond unit(q[0], q[1], q[2], q[3]);
      const double norm = unit.norm();
      // Far from 1 is a wrong column, not rounding: a quaternion of any scale is fine,
      // one of (nearly) zero length has no direction.
      if (!(norm > 1e-9) || !std::isfinite(norm)) {
        throw InputError(source, raw.where(i) + ": orientation (" + format_double(q[0]) + ", " +
                                     format_double(q[1]) + ", " + format_double(q[2]) + ", " +
                                     format_double(q[3]) + ") is not a rotation (zero length)");
      }
      unit.coeffs() /= norm;
      trace.orientation.push_back(unit);
    }
  }
  if (n < 2) {
    throw InputError(source, "need at least 2 samples, found " + std::to_string(n));
  }
  return trace;
}

std::string read_trace_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  if (!in || std::filesystem::is_directory(path, ec)) throw InputError(path, "cannot open file");
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (!ec) engine::check_text_bytes(bytes, path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  if (text.starts_with("\xEF\xBB\xBF")) text.erase(0, 3);
  return text;
}

}  // namespace detail

// --- CSV --------------------------------------------------------------------------------

Trace read_csv_trace(const std::string& path, const TraceColumns& columns) {
  check_scales(path, columns);
  return parse_csv_trace(detail::read_trace_text(path), path, columns);
}

Trace parse_csv_trace(const std::string& text, const std::string& path,
                      const TraceColumns& columns) {
  check_scales(path, columns);
  // A binary file (an .h5, a volume, an archive) is not read as lines: no CSV holds a NUL.
  if (text.find('\0') != std::string::npos) {
    throw InputError(path, "not a CSV text file (it holds NUL bytes: binary data?)");
  }

  // Walk lines by hand so each keeps its 1-based number for messages.
  std::size_t pos = 0;
  int line_number = 0;
  std::string_view line;
  const auto next_line = [&]() {
    if (pos >= text.size()) return false;
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    line = std::string_view(text).substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = end + 1;
    ++line_number;
    return true;
  };

  // Header: the first line that is neither blank nor a comment.
  bool have_header = false;
  while (next_line()) {
    if (!is_skipped_line(line)) {
      have_header = true;
      break;
    }
  }
  if (!have_header) throw InputError(path, "empty file: no header row");
  const std::vector<std::string> names = split_csv_line(line);
  check_unique_columns(names, path);

  const auto find_column = [&](const std::string& name) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      // The header is echoed as printable text, cut short: it may be anything.
      throw InputError(path, "missing column '" + printable(name, 40) +
                                 "' (columns are: " + printable(list, 80) + ")");
    }
    return static_cast<std::size_t>(it - names.begin());
  };
  const std::size_t time_index = find_column(columns.time);
  std::array<std::size_t, 3> position_index;
  for (int a = 0; a < 3; ++a) position_index[a] = find_column(columns.position[a]);
  std::array<std::size_t, 4> orientation_index{};
  if (columns.has_orientation()) {
    for (int c = 0; c < 4; ++c) orientation_index[c] = find_column(columns.orientation[c]);
  }

  RawTrace raw;
  raw.kind = "column";
  std::vector<int> line_numbers;
  const std::uint64_t max_rows = engine::input_limits().max_trace_rows;
  while (next_line()) {
    if (is_skipped_line(line)) continue;
    if (raw.time.size() == max_rows) {
      engine::check_trace_rows(static_cast<double>(max_rows) + 1, path, "it holds at least");
    }
    const std::vector<std::string> fields = split_csv_line(line);
    const std::string where = "line " + std::to_string(line_number);
    if (fields.size() != names.size()) {
      throw InputError(path, where + ": expected " + std::to_string(names.size()) +
                                 " fields, found " + std::to_string(fields.size()));
    }
    const auto number = [&](std::size_t index) {
      double v = 0.0;
      if (!parse_double(fields[index], &v)) {
        throw InputError(path, where + ": column '" + printable(names[index], 40) +
                                   "': not a number: '" + printable(fields[index], 40) + "'");
      }
      return v;
    };
    raw.time.push_back(number(time_index));
    raw.position.push_back(
        {number(position_index[0]), number(position_index[1]), number(position_index[2])});
    if (columns.has_orientation()) {
      raw.orientation.push_back({number(orientation_index[0]), number(orientation_index[1]),
                                 number(orientation_index[2]), number(orientation_index[3])});
    }
    line_numbers.push_back(line_number);
  }
  raw.where = [&](std::size_t i) { return "line " + std::to_string(line_numbers[i]); };
  return finish_trace(path, columns, raw);
}

void write_csv_trace(const Trace& trace, const std::string& path) {
  check_trace_shape(trace, path);
  // Through PATH.partial, renamed once complete (engine/io/output_file.h).
  engine::io::OutputFile file(path);
  std::FILE* out = fdopen(dup(file.fd()), "wb");
  if (out == nullptr) {
    file.discard();
    throw InputError(path, "cannot write " + file.partial_path() + ": " + std::strerror(errno));
  }
  // With an orientation: its quaternion as qw,qx,qy,qz (read back with --orientation-cols).
  const bool turning = !trace.orientation.empty();
  bool ok = std::fputs(turning ? "t,x,y,z,qw,qx,qy,qz\n" : "t,x,y,z\n", out) >= 0;
  for (std::size_t i = 0; ok && i < trace.time_s.size(); ++i) {
    const Vec3d& p = trace.position_mm[i];
    // %.17g round-trips every double exactly.
    ok = std::fprintf(out, "%.17g,%.17g,%.17g,%.17g", trace.time_s[i], p.x(), p.y(), p.z()) > 0;
    if (ok && turning) {
      const Eigen::Quaterniond& q = trace.orientation[i];
      ok = std::fprintf(out, ",%.17g,%.17g,%.17g,%.17g", q.w(), q.x(), q.y(), q.z()) > 0;
    }
    ok = ok && std::fputc('\n', out) != EOF;
  }
  ok = (std::fclose(out) == 0) && ok;
  if (!ok) {
    file.discard();
    throw InputError(path, "cannot write " + file.partial_path());
  }
  file.commit();
}

Trace read_trace(const std::string& path, const TraceColumns& columns) {
  if (has_h5_extension(path)) return read_h5_trace(path, columns);
  if (is_h3d_device_log(path)) return read_h3d_device_log(path);
  return read_csv_trace(path, columns);
}

// --- Transforms ---------------------------------------------------------------------------

Eigen::Matrix3d rotation_from_euler_deg(const Vec3d& xyz_deg) {
  const Vec3d r = xyz_deg * (std::numbers::pi / 180.0);
  // About x first, so it is the rightmost factor.
  return (Eigen::AngleAxisd(r.z(), Vec3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3d::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3d::UnitX()))
      .toRotationMatrix();
}

DeviceTransform fit_trace_into_box(const Trace& trace, const Vec3d& box_min_mm,
                                   const Vec3d& box_max_mm, double margin_fraction) {
  const std::string source = "trace fit";
  if (trace.position_mm.empty()) throw InputError(source, "trace has no samples");
  if (!finite(box_min_mm) || !finite(box_max_mm) ||
      !(box_max_mm.array() > box_min_mm.array()).all()) {
    throw InputError(source, "box must have positive size on every axis");
  }
  if (!(margin_fraction >= 0.0 && margin_fraction < 0.5)) {
    throw InputError(
        source, "margin fraction must be in [0, 0.5) (got " + format_double(margin_fraction) + ")");
  }
  Vec3d lo = trace.position_mm.front();
  Vec3d hi = lo;
  for (const Vec3d& p : trace.position_mm) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3d extent = hi - lo;
  const Vec3d room = (box_max_mm - box_min_mm) * (1.0 - 2.0 * margin_fraction);

  // Only axes the trace moves along limit the scale; a still trace keeps scale 1.
  double scale = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (extent[a] > 0.0) scale = std::min(scale, room[a] / extent[a]);
  }
  if (!std::isfinite(scale)) scale = 1.0;

  DeviceTransform transform;
  transform.scale = scale;
  transform.offset_mm = 0.5 * (box_min_mm + box_max_mm) - scale * 0.5 * (lo + hi);
  return transform;
}

// --- Synthetic traces -----------------------------------------------------------------------

TraceShape parse_trace_shape(const std::string& name, const std::string& source) {
  if (name == "press") return TraceShape::kPress;
  if (name == "press-release") return TraceShape::kPressRelease;
  if (name == "stroke") return TraceShape::kStroke;
  if (name == "circle") return TraceShape::kCircle;
  throw InputError(source, "unknown trace shape '" + name +
                               "' (expected press, press-release, stroke or circle)");
}

Trace make_trace(const TraceMakeOptions& o) {
  require(std::isfinite(o.speed_mm_s) && o.speed_mm_s > 0.0,
          "speed must be positive (got " + format_double(o.speed_mm_s) + ")");
  require(std::isfinite(o.rate_hz) && o.rate_hz > 0.0,
          "rate must be positive (got " + format_double(o.rate_hz) + ")");
  require(std::isfinite(o.travel_mm) && o.travel_mm > 0.0,
          "travel must be positive (got " + format_double(o.travel_mm) + ")");
  require(finite(o.start_mm), "start must be finite");
  require(finite(o.direction) && o.direction.norm() > 0.0, "direction must be non-zero");
  require(std::isfinite(o.hold_s) && o.hold_s >= 0.0,
          "hold time must not be negative (got " + format_double(o.hold_s) + ")");

  const Vec3d dir = o.direction.normalized();
  const Vec3d bottom = o.start_mm + o.travel_mm * dir;
  // The lateral axis, made perpendicular to the direction (stroke and circle only).
  const auto lateral_axis = [&] {
    require(finite(o.lateral), "lateral must be finite");
    const Vec3d l = o.lateral - o.lateral.dot(dir) * dir;
    require(l.norm() > 1e-9 * std::max(1.0, o.lateral.norm()),
            "lateral must not be zero or parallel to direction");
    return Vec3d(l.normalized());
  };

  std::vector<Piece> pieces;
  pieces.push_back(line_piece(o.start_mm, bottom, o.speed_mm_s));
  switch (o.shape) {
    case TraceShape::kPress:
      pieces.push_back(hold_piece(bottom, o.hold_s));
      break;
    case TraceShape::kPressRelease:
      pieces.push_back(hold_piece(bottom, o.hold_s));
      pieces.push_back(line_piece(bottom, o.start_mm, o.speed_mm_s));
      break;
    case TraceShape::kStroke: {
      require(std::isfinite(o.stroke_length_mm) && o.stroke_length_mm > 0.0,
              "stroke length must be positive (got " + format_double(o.stroke_length_mm) + ")");
      const Vec3d end = bottom + o.stroke_length_mm * lateral_axis();
      pieces.push_back(line_piece(bottom, end, o.speed_mm_s));
      pieces.push_back(line_piece(end, end - o.travel_mm * dir, o.speed_mm_s));
      break;
    }
    case TraceShape::kCircle: {
      require(std::isfinite(o.radius_mm) && o.radius_mm > 0.0,
              "radius must be positive (got " + format_double(o.radius_mm) + ")");
      // The bottom point lies on the circle; the centre is radius_mm along lateral from it.
      const Vec3d u = lateral_axis();
      const Vec3d v = dir.cross(u);
      const Vec3d centre = bottom + o.radius_mm * u;
      const double r = o.radius_mm;
      pieces.push_back({2.0 * std::numbers::pi * r / o.speed_mm_s, [centre, u, v, r](double s) {
                          const double angle = 2.0 * std::numbers::pi * s;
                          return Vec3d(centre - r * std::cos(angle) * u + r * std::sin(angle) * v);
                        }});
      pieces.push_back(line_piece(bottom, o.start_mm, o.speed_mm_s));
      break;
    }
  }
  std::erase_if(pieces, [](const Piece& piece) { return !(piece.duration_s > 0.0); });

  std::vector<double> starts;  // start time of each piece
  double total_s = 0.0;
  for (const Piece& piece : pieces) {
    starts.push_back(total_s);
    total_s += piece.duration_s;
  }
  // Samples sit exactly on k / rate; the last one is the first at or after the end, and
  // is clamped to the end point so every shape finishes where it should.
  const double last_k = std::ceil(total_s * o.rate_hz - 1e-9);
  require(last_k + 1 <= kMaxTicks,
          "trace would have " + format_double(last_k + 1) + " samples (too many)");
  const std::size_t count = static_cast<std::size_t>(last_k) + 1;

  Trace trace;
  trace.time_s.reserve(count);
  trace.position_mm.reserve(count);
  std::size_t current = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const double time = static_cast<double>(k) / o.rate_hz;
    while (current + 1 < pieces.size() && starts[current + 1] <= time) ++current;
    const Piece& piece = pieces[current];
    const double s = std::clamp((time - starts[current]) / piece.duration_s, 0.0, 1.0);
    trace.time_s.push_back(time);
    trace.position_mm.push_back(piece.at(s));
  }
  return trace;
}

}  // namespace hapvox::haptics
