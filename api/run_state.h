#pragma once
// One run's mutable state of a model (MuJoCo's mjData beside the constant Model), wired as
// `hapvox replay` wires it (tools/cmd_replay.cc, tools/replay_fem.cc):
//   voxel  the force stage and, when sculpting, the run's own copy of the densities, the
//          mass grid and the relaxation stage;
//   fem    the hand-offs, the force stage and the FEM stage, whose first snapshot is made
//          where the tool starts (start()).

#include <memory>

#include "api/internal.h"
#include "haptics/double_buffered_field.h"
#include "haptics/surface_channel.h"

namespace hapvox::api {

class ModelRun {
 public:
  /// `realtime`: the background stage runs on its own thread (the relaxation publishes into
  /// a double buffer).
  ModelRun(const Model::Impl& model, bool realtime);
  ModelRun(const ModelRun&) = delete;
  ModelRun& operator=(const ModelRun&) = delete;
  ~ModelRun();

  /// Before the first tick, with the tool's first position (volume mm): the FEM model makes
  /// its background stage there (allocates). Nothing for the voxel model.
  void start(const haptics::Vec3d& tool_mm);
  bool started() const { return force_ != nullptr && (fem_model_ == nullptr || fem_ != nullptr); }

  haptics::ForceStage& force() { return *force_; }
  /// The relaxation (sculpting) or the FEM stage; null for an elastic voxel run.
  haptics::BackgroundStage* background();

  /// What the model adds to a session: its attributes and, for the FEM, its steps and mesh.
  void write_session(haptics::SessionWriter& session, double t0_s, double rate_hz) const;

 private:
  // Voxel.
  std::unique_ptr<engine::DensityField> field_;  // sculpting: the run's own densities
  std::unique_ptr<haptics::DoubleBufferedField> buffers_;
  std::unique_ptr<const engine::ToolForceModel> own_model_;
  std::unique_ptr<engine::MassGrid> mass_;
  haptics::SurfaceChangeChannel channel_;
  std::unique_ptr<haptics::RelaxationStage> relaxation_;
  // FEM.
  const haptics::FemModel* fem_model_ = nullptr;
  std::unique_ptr<haptics::FemHandoff> handoff_;
  std::unique_ptr<haptics::FemBackgroundStage> fem_;
  // Either's force stage.
  std::unique_ptr<haptics::ForceStage> force_;
};

}  // namespace hapvox::api
