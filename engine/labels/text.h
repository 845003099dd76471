#pragma once
// Numbers and vectors as error messages show them (internal to engine/labels).

#include <charconv>
#include <string>

#include "engine/density_field.h"

namespace hapvox::engine::labels::detail {

/// Shortest text that reads back as the same value ("0.45", "1e+06", "-1", "nan").
template <typename T>
std::string number(T value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

/// "(x, y, z)".
template <typename V>
std::string triple(const V& v) {
  return "(" + number(v.x()) + ", " + number(v.y()) + ", " + number(v.z()) + ")";
}

/// "NxMxK".
inline std::string size_text(const Vec3i& dims) {
  return number(dims.x()) + "x" + number(dims.y()) + "x" + number(dims.z());
}

}  // namespace hapvox::engine::labels::detail
