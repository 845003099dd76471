#pragma once
// Comparing a live session with its trace's lockstep replay (tests/tools): what a realtime
// run computed is the replay's, tick for tick; only when ticks ran, and so the ramp factor a
// watchdog trip or a silence sent them with, may differ.

#include <gtest/gtest.h>

#include <cstddef>
#include <string>
#include <vector>

#include "haptics/session.h"

namespace hapvox::testing {

/// Expects every named column equal on every tick (e.g. /displacement_mm, /relax/...).
inline void expect_same_columns(const std::string& live, const std::string& replayed,
                                const std::vector<std::string>& columns) {
  for (const std::string& column : columns) {
    EXPECT_EQ(haptics::read_session_column(live, column),
              haptics::read_session_column(replayed, column))
        << live << " " << column;
  }
}

/// Expects /force_n equal to the last bit on every tick both sessions sent with the same
/// /force_scale; returns how many ticks that was.
inline std::size_t expect_same_forces_at_same_ramp(const std::string& live,
                                                   const std::string& replayed) {
  const std::vector<double> live_force = haptics::read_session_column(live, "/force_n");
  const std::vector<double> again_force = haptics::read_session_column(replayed, "/force_n");
  const std::vector<double> live_scale = haptics::read_session_column(live, "/force_scale");
  const std::vector<double> again_scale = haptics::read_session_column(replayed, "/force_scale");
  EXPECT_EQ(live_force.size(), again_force.size());
  EXPECT_EQ(live_scale.size(), again_scale.size());
  if (live_force.size() != again_force.size() || live_scale.size() != again_scale.size()) return 0;
  std::size_t same_ramp = 0;
  for (std::size_t k = 0; k < live_scale.size(); ++k) {
    if (live_scale[k] != again_scale[k]) continue;
    ++same_ramp;
    for (int a = 0; a < 3; ++a) {
      if (live_force[3 * k + a] != again_force[3 * k + a]) {
        ADD_FAILURE() << "tick " << k << " axis " << a << ": " << live_force[3 * k + a] << " vs "
                      << again_force[3 * k + a];
        return same_ramp;
      }
    }
  }
  return same_ramp;
}

}  // namespace hapvox::testing
