#pragma once
// What hapvox's TOML readers share (materials files, incision files, sweep manifests): a
// reporter of one file's mistakes at their lines, and the parse that turns toml++'s syntax
// errors into the same one-line InputError. Header-only: include it only in a file compiled
// with toml++ (engine/labels, engine/proxy, haptics/sweep_manifest.cc and their fuzz targets).

#include <toml++/toml.h>

#include <cstdio>
#include <string>
#include <string_view>
#include <utility>

#include "engine/errors.h"

namespace hapvox::engine {

/// Errors at a line of one file: InputError("SOURCE:LINE", problem).
class TomlReporter {
 public:
  explicit TomlReporter(std::string source) : source_(std::move(source)) {}
  const std::string& source() const { return source_; }

  std::string at(int line) const { return source_ + ":" + std::to_string(line); }
  /// A problem quotes what the file holds (a model's name, a key), which TOML's escapes can
  /// give a line break: control characters are written \xHH, so the error stays one line.
  /// Other bytes pass as they are (UTF-8 names stay readable).
  [[noreturn]] void fail(int line, const std::string& problem) const {
    throw InputError(at(line), one_line(problem));
  }
  [[noreturn]] void fail(const toml::node& node, const std::string& problem) const {
    fail(line(node), problem);
  }
  static int line(const toml::node& node) { return static_cast<int>(node.source().begin.line); }
  static std::string one_line(const std::string& text) {
    std::string out;
    for (const char c : text) {
      const auto byte = static_cast<unsigned char>(c);
      if (byte >= 0x20 && byte != 0x7f) {
        out += c;
        continue;
      }
      char escaped[5];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", byte);
      out += escaped;
    }
    return out;
  }

 private:
  std::string source_;
};

/// How deep hapvox's TOML files may nest: tables, dotted keys, arrays and inline tables
/// together. Theirs nest two or three deep. toml++'s parser recurses once a level, through
/// the tables a dotted key implies as through nested values (a backtrace of 100,000 parts
/// showed 30,000 frames in toml::parse before SIGSEGV), so a header of 30,000 dotted key
/// parts, 60 kB, overflowed hapvox's stack before any of our checks ran: the depth is
/// checked on the text, before toml++ reads it.
inline constexpr int kMaxTomlDepth = 64;

namespace detail {

/// A scan for parse_toml: the deepest nesting the text reaches and the line it does. A
/// nesting is the brackets and braces open (outside strings and comments) plus the longest
/// run of dot-joined keys; numbers and dates count too ("1.5" is two), which only
/// overstates a depth, never hides one. Linear in the text and without recursion, so it
/// runs before toml++ sees the text.
struct TomlDepthScan {
  int depth = 0;
  int line = 1;
};

inline bool toml_bare_key_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-';
}

// The index just past the string starting at text[i] (a quote), counting its newlines.
inline std::size_t toml_string_end(std::string_view text, std::size_t i, int* line) {
  const char quote = text[i];
  const bool multi = text.substr(i, 3) == std::string_view(quote == '"' ? "\"\"\"" : "'''");
  std::size_t j = i + (multi ? 3 : 1);
  while (j < text.size()) {
    const char c = text[j];
    if (c == '\n') {
      if (!multi) return j;  // unterminated: toml++ says so; the caller counts this line
      ++*line;
    }
    if (c == '\\' && quote == '"') {
      ++j;  // the escaped character, a line break too (a multi-line string's line-ending \)
      if (j < text.size() && text[j] == '\n') ++*line;
    } else if (c == quote && (!multi || text.substr(j, 3) == text.substr(i, 3))) {
      return j + (multi ? 3 : 1);
    }
    ++j;
  }
  return j;
}

inline TomlDepthScan toml_depth(std::string_view text) {
  TomlDepthScan deepest;
  int open = 0;      // brackets and braces open
  int run = 0;       // keys in the current dotted run
  bool dot = false;  // a dot ended the run so far
  bool in_key = false;
  int line = 1;
  const auto segment = [&] {
    run = dot ? run + 1 : 1;
    dot = false;
    if (open + run > deepest.depth) deepest = {open + run, line};
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool key_char = toml_bare_key_char(c);
    if (in_key && !key_char) in_key = false;
    if (key_char) {
      if (!in_key) segment();
      in_key = true;
    } else if (c == '"' || c == '\'') {
      i = toml_string_end(text, i, &line) - 1;
      segment();
    } else if (c == '.') {
      dot = run > 0;
    } else if (c == ' ' || c == '\t') {
      continue;  // "a . b" is one dotted key
    } else {
      run = 0;
      dot = false;
      if (c == '#') {
        while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
      } else if (c == '\n') {
        ++line;
      } else if (c == '[' || c == '{') {
        ++open;
        if (open > deepest.depth) deepest = {open, line};
      } else if ((c == ']' || c == '}') && open > 0) {
        --open;
      }
    }
  }
  return deepest;
}

}  // namespace detail

/// Parses `text` as TOML; a syntax error is the reporter's InputError at its line, with
/// toml++'s description made printable (at most 200 characters). Text nesting deeper than
/// kMaxTomlDepth is refused at the line where it does, before toml++ reads it.
inline toml::table parse_toml(std::string_view text, const TomlReporter& r) {
  if (const detail::TomlDepthScan scan = detail::toml_depth(text); scan.depth > kMaxTomlDepth) {
    r.fail(scan.line, "nests " + std::to_string(scan.depth) +
                          " levels deep (tables, dotted keys, arrays and inline tables), over "
                          "the limit of " +
                          std::to_string(kMaxTomlDepth));
  }
  try {
    return toml::parse(text, std::string_view(r.source()));
  } catch (const toml::parse_error& e) {
    r.fail(static_cast<int>(e.source().begin.line), printable(e.description(), 200));
  }
}

}  // namespace hapvox::engine
