#include "api/run_state.h"

#include "haptics/mesh_file.h"

namespace hapvox::api {

ModelRun::ModelRun(const Model::Impl& model, bool realtime) {
  if (model.fem != nullptr) {
    fem_model_ = model.fem.get();
    handoff_ = std::make_unique<haptics::FemHandoff>();
    force_ = std::make_unique<haptics::FemForceStage>(*fem_model_, *handoff_);
    return;
  }
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
  auto force = std::make_unique<haptics::VoxelForceStage>(
      *tool_model, plastic ? &channel_ : nullptr, buffers_.get());
  if (plastic) {
    relaxation_ = realtime ? std::make_unique<haptics::RelaxationStage>(*mass_, channel_, *buffers_,
                                                                        model.budget)
                           : std::make_unique<haptics::RelaxationStage>(*mass_, channel_, *field_,
                                                                        *force, model.budget);
  }
  force_ = std::move(force);
}

// The stages go before what they point into (the relaxation into the grid and channel).
ModelRun::~ModelRun() {
  fem_.reset();
  relaxation_.reset();
  force_.reset();
}

void ModelRun::start(const haptics::Vec3d& tool_mm) {
  if (fem_model_ != nullptr && fem_ == nullptr) {
    fem_ = std::make_unique<haptics::FemBackgroundStage>(*fem_model_, *handoff_, tool_mm);
  }
}

haptics::BackgroundStage* ModelRun::background() {
  if (fem_model_ != nullptr) return fem_.get();
  return relaxation_.get();
}

void ModelRun::write_session(haptics::SessionWriter& session, double t0_s, double rate_hz) const {
  force_->write_attributes(session);
  if (fem_ != nullptr) {
    fem_->write_session(session, t0_s, rate_hz);
    haptics::write_proxy_mesh(session.file_handle(), fem_model_->proxy());
  }
}

}  // namespace hapvox::api
