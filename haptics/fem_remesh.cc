#include "haptics/fem_remesh.h"

#include <chrono>

#include "haptics/fem_model.h"

namespace hapvox::haptics {

std::unique_ptr<FemRemesh> build_remesh(const LabelChange& change, const FemModel& previous) {
  const auto start = std::chrono::steady_clock::now();
  auto remesh = std::make_unique<FemRemesh>();
  remesh->model = std::make_unique<FemModel>(change.build_proxy(), previous.options());
  const FemModel& model = *remesh->model;
  if (previous.options().solver == FemSolver::kCorotational) {
    remesh->corotational = std::make_unique<engine::fem::CorotationalFem>(
        model.mesh(), model.proxy().materials, model.fixed_dofs(), previous.options().corotational);
  }
  remesh->from_previous = engine::fem::locate_points(previous.mesh(), model.mesh().rest_mm);
  remesh->change_tick = change.tick;
  remesh->description = change.description;
  remesh->build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return remesh;
}

}  // namespace hapvox::haptics
