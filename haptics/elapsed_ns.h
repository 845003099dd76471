#pragma once
// Nanoseconds between two steady-clock instants: the unit of every timing column a session
// records (lateness, step and settle times).

#include <chrono>
#include <cstdint>

namespace hapvox::haptics {

inline std::int64_t ns_between(std::chrono::steady_clock::time_point from,
                               std::chrono::steady_clock::time_point to) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(to - from).count();
}

}  // namespace hapvox::haptics
