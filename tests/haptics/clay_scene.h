#pragma once
// The realtime sculpting scene the haptics tests share: an 8 mm tool stroking a 48^3 clay
// block (face at z = 23.5 mm), with the double-buffered field, mass grid and channel a
// realtime replay needs.

#include "engine/relax.h"
#include "engine/volume_io.h"
#include "haptics/double_buffered_field.h"
#include "haptics/realtime.h"
#include "haptics/voxel_model.h"

namespace hapvox::haptics::fixtures {

inline TraceDevice clay_stroke_device(double rate_hz, double speed_mm_s) {
  TraceMakeOptions make;
  make.shape = TraceShape::kStroke;
  make.start_mm = Vec3d(14.3, 24.4, 32.0);
  make.travel_mm = 9.0;
  make.speed_mm_s = speed_mm_s;
  make.stroke_length_mm = 20.0;
  ResampleOptions resample_options;
  resample_options.rate_hz = rate_hz;
  return TraceDevice(resample(make_trace(make), resample_options), DeviceTransform{});
}

inline engine::ToolForceOptions clay_tool() {
  engine::ToolForceOptions options;
  options.tool.diameter_mm = 8.0;
  options.plastic.enabled = true;
  options.plastic.yield_stress_pa = 20e3;
  return options;
}

struct ClayScene {
  const engine::DensityField field = engine::generate_volume("block:dims=48");
  DoubleBufferedField buffers{field};
  const engine::ToolForceModel model{buffers.buffer(0), clay_tool()};
  engine::MassGrid mass{field};
  SurfaceChangeChannel channel;
  RealtimeSculpt sculpt{&mass, &buffers, &channel, 2000, 8};
};

}  // namespace hapvox::haptics::fixtures
