#include "api/run_state.h"

namespace hapvox::api {

VoxelRun::VoxelRun(const Model::Impl& model, bool realtime) {
  const engine::ToolForceModel* tool_model = model.elastic.get();
  const bool plastic = model.force.plastic.enabled;
  if (plastic) {
    // The run sculpts its own copy: the Model stays constant.
    const engine::DensityField& shared = model.volume.impl().field;
    field_ = std::make_unique<engine::DensityField>(shared.grid().deepCopy(),
                                                    shared.voxel_size_mm(), shared.origin_mm(),
                                                    shared.dims(), shared.direction());
    if (realtime) buffers_ = std::make_unique<haptics::DoubleBufferedField>(*field_);
    own_model_ = std::make_unique<const engine::ToolForceModel>(
        buffers_ ? buffers_->buffer(0) : *field_, model.force);
    tool_model = own_model_.get();
    mass_ = std::make_unique<engine::MassGrid>(*field_, model.relax);
  }
  force_ = std::make_unique<haptics::VoxelForceStage>(*tool_model, plastic ? &channel_ : nullptr,
                                                      buffers_.get());
  if (plastic) {
    relaxation_ = realtime ? std::make_unique<haptics::RelaxationStage>(*mass_, channel_, *buffers_,
                                                                        model.budget)
                           : std::make_unique<haptics::RelaxationStage>(*mass_, channel_, *field_,
                                                                        *force_, model.budget);
  }
}

}  // namespace hapvox::api
