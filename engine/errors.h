#pragma once
// Typed errors for user input (files, traces, configs, flags). Invariants use CHECKs
// (engine/check.h) instead: an InputError is the user's to fix, a failed CHECK is ours.

#include <cstdio>
#include <string>
#include <string_view>

#include "hapvox/error.h"  // InputError: public, thrown through the API unchanged

namespace hapvox {

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
