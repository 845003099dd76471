#pragma once
// One run's mutable state of a voxel model (MuJoCo's mjData beside the constant Model): the
// force stage and, when sculpting, its own copy of the densities, the mass grid and the
// relaxation stage, wired as `hapvox replay` wires them (tools/cmd_replay.cc).

#include <memory>

#include "api/internal.h"
#include "haptics/double_buffered_field.h"
#include "haptics/surface_channel.h"

namespace hapvox::api {

class VoxelRun {
 public:
  /// `realtime`: the relaxation runs on its own thread and publishes into a double buffer.
  VoxelRun(const Model::Impl& model, bool realtime);
  VoxelRun(const VoxelRun&) = delete;
  VoxelRun& operator=(const VoxelRun&) = delete;

  haptics::VoxelForceStage& force() { return *force_; }
  /// Null for an elastic run.
  haptics::RelaxationStage* relaxation() { return relaxation_.get(); }

 private:
  std::unique_ptr<engine::DensityField> field_;  // sculpting: the run's own densities
  std::unique_ptr<haptics::DoubleBufferedField> buffers_;
  std::unique_ptr<const engine::ToolForceModel> own_model_;
  std::unique_ptr<engine::MassGrid> mass_;
  haptics::SurfaceChangeChannel channel_;
  std::unique_ptr<haptics::VoxelForceStage> force_;
  std::unique_ptr<haptics::RelaxationStage> relaxation_;
};

}  // namespace hapvox::api
