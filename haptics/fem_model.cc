#include "haptics/fem_model.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::haptics {

const char* fem_interaction_name(FemInteraction interaction) {
  return interaction == FemInteraction::kPress ? "press" : "grab";
}

const char* fem_solver_name(FemSolver solver) {
  return solver == FemSolver::kLinear ? "linear" : "corotational";
}

FemInteraction parse_fem_interaction(const std::string& name, const std::string& source) {
  if (name == "press") return FemInteraction::kPress;
  if (name == "grab") return FemInteraction::kGrab;
  throw InputError(source, "unknown interaction '" + name + "' (press or grab)");
}

FemSolver parse_fem_solver(const std::string& name, const std::string& source) {
  if (name == "linear") return FemSolver::kLinear;
  if (name == "corotational") return FemSolver::kCorotational;
  throw InputError(source, "unknown FEM solver '" + name + "' (linear or corotational)");
}

void validate(const FemOptions& o) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  const std::string source = "fem options";
  if (!positive(o.tool_radius_mm)) throw InputError(source, "the tool radius must be > 0 mm");
  if (!positive(o.kept_steps_mb)) {
    throw InputError(source, "the FEM steps' memory budget must be > 0 MB");
  }
  if (!positive(o.coupling_n_per_mm)) {
    throw InputError(source, "the coupling stiffness must be > 0 N/mm");
  }
  if (!std::isfinite(o.candidate_margin_mm) || o.candidate_margin_mm < 0.0) {
    throw InputError(source, "the candidate margin must be >= 0 mm");
  }
  if (o.fem_every_ticks == 0) throw InputError(source, "the FEM must run every >= 1 ticks");
  if (!(o.fem_rate_hz >= 1.0 && o.fem_rate_hz <= 1000.0)) {
    throw InputError(source, "the FEM rate must lie in [1, 1000] Hz");
  }
}

FemModel::FemModel(engine::proxy::ProxyMesh proxy, const FemOptions& options)
    : proxy_(std::move(proxy)), options_(options) {
  validate(options_);
  HAPVOX_CHECK_EQ(proxy_.vertex_classes.size(), std::size_t(proxy_.mesh.vertex_count()));
  for (std::int32_t v = 0; v < proxy_.mesh.vertex_count(); ++v) {
    if (proxy_.vertex_classes[v] != engine::fem::VertexClass::kFixed) continue;
    for (int axis = 0; axis < 3; ++axis) fixed_dofs_.push_back(engine::fem::dof_index(v, axis));
  }
  // Prescribed displacements (an incision's opening) are held like the fixed vertices, at
  // their values.
  prescribed_mm_ = Eigen::VectorXd::Zero(3 * proxy_.mesh.vertex_count());
  std::vector<char> held(proxy_.mesh.vertex_count(), 0);
  for (const auto& [dof, mm] : proxy_.prescribed_mm) {
    HAPVOX_CHECK(dof >= 0 && dof < prescribed_mm_.size());
    prescribed_mm_(dof) = mm;
    held[dof / 3] = 1;
    if (proxy_.vertex_classes[dof / 3] != engine::fem::VertexClass::kFixed) {
      fixed_dofs_.push_back(dof);
    }
  }
  std::sort(fixed_dofs_.begin(), fixed_dofs_.end());
  linear_ = std::make_unique<engine::fem::LinearFem>(proxy_.mesh, proxy_.materials, fixed_dofs_);
  std::vector<char> on_surface(proxy_.mesh.vertex_count(), 0);
  for (const engine::fem::Triangle& face : engine::fem::boundary_faces(proxy_.mesh)) {
    for (const std::int32_t v : face) on_surface[v] = 1;
  }
  for (std::int32_t v = 0; v < proxy_.mesh.vertex_count(); ++v) {
    if (proxy_.vertex_classes[v] == engine::fem::VertexClass::kFixed || held[v]) continue;
    free_vertices_.push_back(v);
    if (on_surface[v]) surface_vertices_.push_back(v);
  }
}

// --- Force stage ---

FemForceStage::FemForceStage(const FemModel& model, FemHandoff& handoff)
    : model_(model), handoff_(handoff) {}

Vec3d FemForceStage::step(const Vec3d& tool_center_mm, TickRecord& row) noexcept {
  const ContactSnapshot& snapshot = handoff_.snapshots.read();
  const FemOptions& o = model_.options();
  // The press normals point from the proxy (the sphere's centre), taken from the last tick.
  const Vec3d proxy_hint_mm = has_proxy_ ? last_.proxy_mm : tool_center_mm;
  last_ = o.interaction == FemInteraction::kPress
              ? solve_press(snapshot, tool_center_mm, proxy_hint_mm, o.tool_radius_mm,
                            o.coupling_n_per_mm, scratch_)
              : solve_grab(snapshot, tool_center_mm, o.coupling_n_per_mm);
  has_proxy_ = true;
  if (!last_.converged) {
    // Never a step from a fault: hold the last good force (and its proxy).
    ++unconverged_;
    last_.force_n = last_good_force_n_;
    last_.proxy_mm = tool_center_mm + last_good_force_n_ / o.coupling_n_per_mm;
  }
  Vec3d force_n = last_.force_n;
  if (!force_n.allFinite()) {
    ++nonfinite_;
    force_n.setZero();
    last_.proxy_mm = tool_center_mm;
  }
  last_good_force_n_ = force_n;
  const bool contact = last_.active > 0;
  if (contact && !in_contact_) ++contact_onsets_;
  in_contact_ = contact;
  row.displacement_mm = last_.proxy_mm - tool_center_mm;  // the coupling's stretch
  row.contact = contact ? 1 : 0;
  handoff_.device.publish(RenderToolState{tool_center_mm, row.displacement_mm, contact, tick_++});
  return force_n;
}

ForceStageCounters FemForceStage::counters() const noexcept {
  return ForceStageCounters{contact_onsets_, nonfinite_};
}

void FemForceStage::write_attributes(SessionWriter& session) const {
  const FemOptions& o = model_.options();
  session.set_attribute("model", std::string("fem"));
  session.set_attribute("fem_interaction", std::string(fem_interaction_name(o.interaction)));
  session.set_attribute("fem_solver", std::string(fem_solver_name(o.solver)));
  session.set_attribute("tool_radius_mm", o.tool_radius_mm);
  session.set_attribute("coupling_n_per_mm", o.coupling_n_per_mm);
  session.set_attribute("candidate_margin_mm", o.candidate_margin_mm);
  session.set_attribute("fem_every_ticks", static_cast<std::int64_t>(o.fem_every_ticks));
  session.set_attribute("fem_rate_hz", o.fem_rate_hz);
  session.set_attribute("mesh_vertices", std::int64_t{model_.mesh().vertex_count()});
  session.set_attribute("mesh_tets", std::int64_t{model_.mesh().tet_count()});
  session.set_attribute("materials", model_.proxy().materials_source);
  session.set_attribute("unconverged_contact_solves", static_cast<std::int64_t>(unconverged_));
}

}  // namespace hapvox::haptics
