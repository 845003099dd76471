#pragma once
// `hapvox render`'s flags, shared by the voxel model's frames (tools/cmd_render.cc) and the
// proxy-FEM model's (tools/render_fem.cc).

#include <cstddef>
#include <memory>
#include <string>

#include "haptics/replay.h"
#include "tools/cli.h"
#include "tools/fem_options.h"
#include "tools/render_output.h"

namespace hapvox::cli {

struct RenderCommandFlags {
  std::string volume;
  std::string output;
  std::string trace_path;
  MappingFlags mapping;
  TraceFlags trace;
  TransformFlags transform;
  ForceFlags force;
  RenderFlags render;
  int turntable = 0;
  std::size_t every_ticks = 100;
  bool plastic = false;
  bool video = false;
  bool quiet = false;
  // The deformation model: "voxel" (Prados' FFD) or "fem" (Nakao's proxy mesh).
  std::string model = "voxel";
  FemCliOptions fem_mesh;  // --materials, --labels, --seed, --spacing-mm, ...
  FemRunFlags fem_run;     // --interaction, --coupling-n-per-mm, --fem-every-ticks, ...
};

/// The --trace's device (InputError for a trace without samples); null without --trace.
std::unique_ptr<haptics::TraceDevice> render_trace_device(const RenderCommandFlags& f,
                                                          const engine::DensityField& field);

/// Stills, or with `turntable` > 0 that many frames of a full turn around the volume.
void draw_stills(FrameRecorder& recorder, int turntable);

/// `render --model fem` (tools/render_fem.cc): the frames of a lockstep FEM replay of the
/// trace, or stills and a turntable of the volume through the proxy path when there is none.
void run_fem_render(const RenderCommandFlags& f);

}  // namespace hapvox::cli
