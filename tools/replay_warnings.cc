// Warnings before a replay: a trace that misses the volume, a tool that starts inside it.

#include <cstdio>

#include "engine/errors.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

std::string mm_text(const Eigen::Vector3d& v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%g, %g, %g)", v.x(), v.y(), v.z());
  return text;
}

}  // namespace

std::vector<std::string> replay_warnings(const std::string& trace_path,
                                         const engine::ToolForceModel& model,
                                         const haptics::TraceDevice& device) {
  std::vector<std::string> warnings;
  if (device.tick_count() == 0) return warnings;
  // Wholly outside: at no tick does the tool sphere meet the box of the volume's voxels
  // [0, dims), in volume mm (the distance from its centre to the box exceeds its radius).
  const engine::DensityField& field = model.field();
  const Eigen::Vector3d lo = field.world_min_mm();
  const Eigen::Vector3d hi = field.world_max_mm();
  const double radius = model.tool_radius_mm();
  Eigen::Vector3d path_lo = device.tool_position_mm(0);
  Eigen::Vector3d path_hi = path_lo;
  bool meets = false;
  for (std::size_t tick = 0; tick < device.tick_count(); ++tick) {
    const Eigen::Vector3d c = device.tool_position_mm(tick);
    path_lo = path_lo.cwiseMin(c);
    path_hi = path_hi.cwiseMax(c);
    meets = meets || (c - c.cwiseMax(lo).cwiseMin(hi)).norm() <= radius;
  }
  if (!meets) {
    warnings.push_back(trace_path + ": the tool never reaches the volume: its centre stays in " +
                       mm_text(path_lo) + " .. " + mm_text(path_hi) + " mm, the volume's box is " +
                       mm_text(lo) + " .. " + mm_text(hi) +
                       " mm (check --offset-mm, --scale, --rotate-deg or --fit)");
  }
  // Inside at the first tick: the same first step as the loop's, on a state of its own,
  // before the loop can change the field.
  engine::ToolForceState first = model.make_state();
  model.step(device.tool_position_mm(0), first);
  if (first.started_in_contact > 0) {
    warnings.push_back(trace_path + ": the tool starts inside the material at " +
                       mm_text(device.tool_position_mm(0)) +
                       " mm: with no free position before that contact, its force starts from "
                       "zero there rather than at the surface");
  }
  return warnings;
}

void print_warnings(const std::vector<std::string>& warnings) {
  std::fflush(stdout);
  for (const std::string& warning : warnings) {
    std::fprintf(stderr, "hapvox: warning: %s\n", printable(warning, 400).c_str());
  }
}

}  // namespace hapvox::cli
