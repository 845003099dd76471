#pragma once
// Typed errors for user input (files, traces, configs, flags). Invariants use CHECKs
// (engine/check.h) instead: an InputError is the user's to fix, a failed CHECK is ours.

#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>

namespace hapvox {

/// A problem with something the user gave us. what() reads "SOURCE: PROBLEM", where
/// SOURCE names the file (or flag) and PROBLEM says what is wrong with it.
class InputError : public std::runtime_error {
 public:
  InputError(std::string source, std::string problem)
      : std::runtime_error(source + ": " + problem),
        source_(std::move(source)),
        problem_(std::move(problem)) {}

  const std::string& source() const { return source_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string source_;
  std::string problem_;
};

/// `text` made safe for a one-line message: bytes outside printable ASCII (control bytes,
/// newlines, anything >= 0x80) as \xNN, and cut after about `max_chars` characters with
/// "..." appended. For echoing file contents (or anything else not ours) in errors.
inline std::string printable(std::string_view text, std::size_t max_chars = 80) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    char piece[5] = {static_cast<char>(c), '\0', '\0', '\0', '\0'};
    if (c < 0x20 || c > 0x7e) std::snprintf(piece, sizeof piece, "\\x%02X", c);
    const std::string_view next(piece);
    if (out.size() + next.size() > max_chars) return out + "...";
    out += next;
  }
  return out;
}

}  // namespace hapvox
