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

/// Parses `text` as TOML; a syntax error is the reporter's InputError at its line, with
/// toml++'s description made printable (at most 200 characters).
inline toml::table parse_toml(std::string_view text, const TomlReporter& r) {
  try {
    return toml::parse(text, std::string_view(r.source()));
  } catch (const toml::parse_error& e) {
    r.fail(static_cast<int>(e.source().begin.line), printable(e.description(), 200));
  }
}

}  // namespace hapvox::engine
