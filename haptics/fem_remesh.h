#pragma once
// Rebuilding the proxy-FEM model when the labels change in the middle of a run (Nakao's
// labels are the user's handle on the volume: a region newly fixed or freed, or two regions
// merged, means a new label-conforming mesh and a new factorised stiffness).
//
//   LabelChange  at a tick, a new proxy mesh to build: a function the application gives
//                (e.g. the labels with one label relabelled, meshed with the run's options)
//   FemRemesh    what the build makes, ready to take over: the model (mesh, factorised K),
//                the co-rotational solver's rest factor, and every new vertex located in the
//                previous mesh (engine/fem/field_transfer.h), so that taking over costs the
//                FEM thread one interpolation pass and no factorisation.
//
// FemBackgroundStage (haptics/fem_model.h) runs the changes: in lockstep it builds at the
// first FEM step at or after the change's tick and takes the new model over in that step
// (bit-reproducible); in realtime it starts the build on a thread of its own there, keeps
// stepping the old model meanwhile (the force thread keeps reading snapshots, and never
// waits), and takes the new model over at its first step after the build finished.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "engine/fem/corotational.h"
#include "engine/fem/field_transfer.h"
#include "engine/proxy/proxy_mesh.h"

namespace hapvox::haptics {

class FemModel;

/// A change of labels during a run.
struct LabelChange {
  std::int64_t tick = 0;    // the force tick from which it applies
  std::string description;  // for reports, e.g. "label 3 -> 1"
  /// Builds the proxy mesh of the changed labels (on the thread that rebuilds; may throw
  /// InputError: lockstep stops the run with it; realtime stops the FEM's steps, the force
  /// thread keeping the last snapshot, and reports it at the end of the run).
  std::function<engine::proxy::ProxyMesh()> build_proxy;
};

/// A rebuilt model, ready to take over from the one it was built against.
struct FemRemesh {
  std::unique_ptr<FemModel> model;
  std::unique_ptr<engine::fem::CorotationalFem> corotational;  // co-rotational solver only
  /// Vertex v of the new mesh located in the previous mesh (its rest positions).
  std::vector<engine::fem::TetPoint> from_previous;
  std::int64_t change_tick = 0;  // the tick the change was due
  std::int64_t taken_tick = 0;   // the tick of the FEM step that took it over
  double build_s = 0.0;          // wall time of the build
  int captured_vertices = 0;     // grab: captured again on the new mesh (0: let go)
  std::string description;
};

/// Builds the change's proxy mesh and model with `previous`'s options, factorises it, and
/// locates its vertices in `previous`'s mesh. Any thread; `previous` is only read.
std::unique_ptr<FemRemesh> build_remesh(const LabelChange& change, const FemModel& previous);

}  // namespace hapvox::haptics
