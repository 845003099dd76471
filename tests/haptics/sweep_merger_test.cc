#include "haptics/sweep_merger.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace hapvox::haptics {
namespace {

engine::SurfaceChange change_at(const Eigen::Vector3d& at_mm, std::int64_t event,
                                double radius_mm = 4.0) {
  engine::SurfaceChange change;
  change.from_mm = change.position_mm = at_mm;
  change.direction = Eigen::Vector3d(0, 0, -1);
  change.radius_mm = radius_mm;
  change.event = event;
  return change;
}

// Every sweep the merger gives out of what is queued: (from, to, event, changes).
struct Sweep {
  engine::SurfaceChange change;
  std::size_t changes = 0;
};
std::vector<Sweep> sweeps_of(SurfaceChangeChannel& channel, SweepMerger& merger) {
  std::vector<Sweep> out;
  Sweep sweep;
  while (merger.next_sweep(channel, sweep.change, &sweep.changes)) out.push_back(sweep);
  return out;
}

// A tool ploughing 0.02 mm a tick along a line: ten queued changes are one capsule from the
// first centre to the last, with the newest event's number.
TEST(SweepMerger, AStraightRunOfChangesIsOneSweepFromTheFirstToTheLast) {
  SurfaceChangeChannel channel;
  for (int i = 0; i < 10; ++i) channel.push(change_at(Eigen::Vector3d(0.02 * i, 0, 0), i));
  SweepMerger merger;
  const std::vector<Sweep> sweeps = sweeps_of(channel, merger);
  ASSERT_EQ(sweeps.size(), 1u);
  EXPECT_EQ(sweeps[0].changes, 10u);
  EXPECT_EQ(sweeps[0].change.from_mm, Eigen::Vector3d(0, 0, 0));
  EXPECT_EQ(sweeps[0].change.position_mm, Eigen::Vector3d(0.18, 0, 0));
  EXPECT_EQ(sweeps[0].change.event, 9);
}

// A corner, a new radius and the cap each start a new sweep; nothing is lost or reordered:
// the sweeps' events end at 4, 9, 41, 44 and their changes add up to all 45.
TEST(SweepMerger, ACornerANewRadiusAndTheCapStartANewSweepLosingNothing) {
  SurfaceChangeChannel channel;
  std::int64_t event = 0;
  for (int i = 0; i < 5; ++i) channel.push(change_at(Eigen::Vector3d(0.02 * i, 0, 0), event++));
  for (int i = 1; i <= 5; ++i) {  // turning 90 degrees: 0.02 mm off the first line at once
    channel.push(change_at(Eigen::Vector3d(0.08, 0.02 * i, 0), event++));
  }
  for (int i = 0; i < 32; ++i) {  // a bigger tool, 32 changes: one full sweep
    channel.push(change_at(Eigen::Vector3d(0.08, 0.1 + 0.02 * i, 0), event++, 6.0));
  }
  for (int i = 0; i < 3; ++i) {
    channel.push(change_at(Eigen::Vector3d(0.08, 0.74 + 0.02 * i, 0), event++, 6.0));
  }
  SweepMerger merger;
  const std::vector<Sweep> sweeps = sweeps_of(channel, merger);
  ASSERT_EQ(sweeps.size(), 4u);
  const std::vector<std::int64_t> last_events = {4, 9, 41, 44};
  const std::vector<std::size_t> changes = {5, 5, 32, 3};
  for (std::size_t s = 0; s < sweeps.size(); ++s) {
    EXPECT_EQ(sweeps[s].change.event, last_events[s]) << s;
    EXPECT_EQ(sweeps[s].changes, changes[s]) << s;
  }
  EXPECT_EQ(sweeps[1].change.from_mm, Eigen::Vector3d(0.08, 0.02, 0));
  EXPECT_EQ(sweeps[2].change.radius_mm, 6.0);
  EXPECT_FALSE(merger.has_carried());
}

// A circle of 15 mm at 0.02 mm a tick bends by 0.02^2 / 30 mm a step: 32 changes stay
// within the tolerance of their chord (sagitta (0.62 mm)^2 / 120 mm = 3 um) and merge.
TEST(SweepMerger, AGentleCurveMergesWithinTheTolerance) {
  SurfaceChangeChannel channel;
  const double radius = 15.0, step = 0.02 / 15.0;
  for (int i = 0; i < 32; ++i) {
    channel.push(change_at(radius * Eigen::Vector3d(std::cos(i * step), std::sin(i * step), 0), i));
  }
  SweepMerger merger;
  EXPECT_EQ(sweeps_of(channel, merger).size(), 1u);
  // A bend of 5 degrees a step does not: each sweep holds the two changes on one line.
  for (int i = 0; i < 6; ++i) {
    const double a = i * 5.0 * M_PI / 180.0;
    channel.push(change_at(radius * Eigen::Vector3d(std::cos(a), std::sin(a), 0), i));
  }
  EXPECT_EQ(sweeps_of(channel, merger).size(), 3u);
}

}  // namespace
}  // namespace hapvox::haptics
