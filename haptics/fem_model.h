#pragma once
// The proxy-FEM model (Nakao et al. 2010) behind the seams of haptics/model_stages.h:
//
//   FemModel            the constant part: the proxy mesh, its prefactored linear stiffness,
//                       the options and the free surface vertices a press can touch
//   FemForceStage       the 1 kHz stage: the press or grab contact solve (haptics/fem_contact.h)
//                       on the snapshot the FEM thread published last; the device position
//                       goes back to the FEM thread through a mailbox
//   FemBackgroundStage  the FEM step: the contact forces at the latest device position, the
//                       displacement (linear: one prefactored solve; co-rotational: one
//                       stiffness-warping step), then the next snapshot: the vertices near
//                       the tool, their compliance W and base positions. Lockstep: every
//                       fem_every_ticks ticks; realtime: its own thread at fem_rate_hz.
//
// Hand-offs are lock-free: a triple buffer of snapshots (FEM -> force thread) and a seqlock
// mailbox of the device position (force -> FEM thread). In lockstep the same hand-offs are
// used on one thread, so both loops run the same code.

#include <array>
#include <atomic>
#include <cstdint>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "engine/fem/corotational.h"
#include "engine/fem/linear_fem.h"
#include "engine/proxy/proxy_mesh.h"
#include "haptics/fem_contact.h"
#include "haptics/fem_remesh.h"
#include "haptics/model_stages.h"
#include "haptics/render_feed.h"
#include "haptics/triple_buffer.h"

namespace hapvox::haptics {

enum class FemInteraction { kPress, kGrab };
enum class FemSolver { kLinear, kCorotational };

/// "press"/"grab", "linear"/"corotational"; parse_* throw InputError(source, ...).
const char* fem_interaction_name(FemInteraction interaction);
const char* fem_solver_name(FemSolver solver);
FemInteraction parse_fem_interaction(const std::string& name, const std::string& source);
FemSolver parse_fem_solver(const std::string& name, const std::string& source);

struct FemOptions {
  FemInteraction interaction = FemInteraction::kPress;
  FemSolver solver = FemSolver::kLinear;
  /// Press: the tool sphere's radius. Grab: the capture radius around the first position.
  double tool_radius_mm = 5.0;
  /// The virtual coupling between device and tool proxy. The rendered stiffness never
  /// exceeds it (the FEM's contact stiffness acts in series), so the passivity bound of a
  /// sampled spring (Colgate & Schenkel 1997), k < 2 b / T, holds for it alone: 1 N/mm at
  /// T = 1 ms needs a device damping b >= 0.5 N s/m (docs/physics.md).
  double coupling_n_per_mm = 1.0;
  /// Press: free surface vertices within this distance of the tool's surface are in the
  /// snapshot, so that they are there before they touch.
  double candidate_margin_mm = 2.0;
  /// Lockstep: one FEM step every this many ticks (10: 100 Hz at 1 kHz).
  std::size_t fem_every_ticks = 10;
  /// Realtime: the FEM thread's rate.
  double fem_rate_hz = 100.0;
  /// What the FEM steps' displacements kept for the session may take (MB): beyond it every
  /// other kept step is let go and from then on only every 2nd (4th, ...) step kept, so a
  /// session of any length keeps them in bounded memory, spread over the whole run
  /// (FemBackgroundStage::frames()).
  double kept_steps_mb = 256.0;
  /// Co-rotational mode: the warped system's solver, and each FEM step's equilibrium
  /// iteration (its tolerance, its safeguard).
  engine::fem::CorotationalOptions corotational;
  engine::fem::EquilibriumOptions equilibrium;
};

/// Throws InputError("fem options", ...) for a radius, coupling, rate or step interval that
/// is not positive and finite, or a negative margin.
void validate(const FemOptions& options);

/// The constant part of a proxy-FEM run (shared by both stages; read-only once built).
class FemModel {
 public:
  /// Validates the options, assembles and factorises the linear stiffness with the fixed
  /// vertices as Dirichlet conditions (InputError when nothing is fixed: a free body).
  FemModel(engine::proxy::ProxyMesh proxy, const FemOptions& options);

  const engine::proxy::ProxyMesh& proxy() const { return proxy_; }
  const engine::fem::TetMesh& mesh() const { return proxy_.mesh; }
  const FemOptions& options() const { return options_; }
  const engine::fem::LinearFem& linear() const { return *linear_; }
  /// The DOFs the FEM holds (Dirichlet): the fixed vertices' and the prescribed ones, sorted.
  const std::vector<int>& fixed_dofs() const { return fixed_dofs_; }
  /// Every DOF's held displacement (mm): the proxy's prescribed_mm, zero elsewhere.
  const Eigen::VectorXd& prescribed_mm() const { return prescribed_mm_; }
  /// Free vertices on the mesh's surface (those a press can touch; not those held
  /// prescribed), in vertex order.
  const std::vector<std::int32_t>& surface_vertices() const { return surface_vertices_; }
  /// Free vertices in vertex order (those a grab can capture; not those held prescribed).
  const std::vector<std::int32_t>& free_vertices() const { return free_vertices_; }

 private:
  engine::proxy::ProxyMesh proxy_;
  FemOptions options_;
  std::vector<int> fixed_dofs_;
  Eigen::VectorXd prescribed_mm_;
  std::unique_ptr<engine::fem::LinearFem> linear_;
  std::vector<std::int32_t> surface_vertices_;
  std::vector<std::int32_t> free_vertices_;
};

/// The hand-offs between the two stages of one run.
struct FemHandoff {
  TripleBuffer<ContactSnapshot> snapshots;  // FEM thread -> force thread
  ToolStateMailbox device;                  // force thread -> FEM thread: center = device
};

/// The proxy-FEM model's 1 kHz stage.
class FemForceStage final : public ForceStage {
 public:
  FemForceStage(const FemModel& model, FemHandoff& handoff);

  Vec3d step(const Vec3d& tool_center_mm, TickRecord& row) noexcept override;
  ForceStageCounters counters() const noexcept override;
  /// model = "fem", interaction, solver, radius, coupling, rates, mesh counts.
  void write_attributes(SessionWriter& session) const override;

  /// Ticks whose press solve did not finish (sent the last converged force instead).
  std::uint64_t unconverged_solves() const { return unconverged_; }
  /// The last tick's solve (tests).
  const ContactSolve& last_solve() const { return last_; }

 private:
  const FemModel& model_;
  FemHandoff& handoff_;
  PressScratch scratch_;
  ContactSolve last_;
  bool has_proxy_ = false;                   // last_.proxy_mm holds a tick's proxy
  Vec3d last_good_force_n_ = Vec3d::Zero();  // held through an unconverged press solve
  std::int64_t tick_ = 0;
  bool in_contact_ = false;
  std::uint64_t contact_onsets_ = 0;
  std::uint64_t unconverged_ = 0;
  std::uint64_t nonfinite_ = 0;
};

/// One FEM step's node displacements.
struct FemFrame {
  std::int64_t tick = 0;                // the force tick whose device position it solved for
  std::vector<double> displacement_mm;  // 3 per vertex of its mesh, x fastest
  int mesh = 0;                         // 0: the run's first mesh; k: the k-th remesh's
  std::uint64_t step = 0;               // the FEM step it is (0: begin()'s)
};

/// The proxy-FEM model's background stage: the FEM.
class FemBackgroundStage final : public BackgroundStage {
 public:
  /// `initial_device_mm` is the device's position at the first tick: the first snapshot
  /// is made there, and a grab captures the free vertices within the tool radius of it
  /// (InputError("grab", ...) when there are none).
  FemBackgroundStage(const FemModel& model, FemHandoff& handoff, const Vec3d& initial_device_mm);
  ~FemBackgroundStage() override;

  /// Label changes to run (haptics/fem_remesh.h), in tick order; before begin().
  void set_label_changes(std::vector<LabelChange> changes);

  void begin() override;
  void run_lockstep_tick(std::size_t tick, TickRecord& row, const LockstepRender* render) override;
  void run_realtime(const std::atomic<bool>& force_done,
                    std::chrono::steady_clock::time_point start, RenderFeed* feed,
                    BackgroundTiming& timing) override;
  void fill_realtime_row(TickRecord&) noexcept override {}
  void wake() noexcept override {}
  SculptSummary finish(const LockstepRender* render, RenderFeed* feed,
                       const std::atomic<bool>* render_finished) override;

  /// The displacements of the FEM steps kept, in order: every step while they fit in
  /// FemOptions::kept_steps_mb, then every kept_every()-th (begin()'s, step 0, always), and
  /// always the last step made.
  const std::vector<FemFrame>& frames() const { return frames_; }
  /// 1, or the power of two the steps kept were thinned to.
  std::uint64_t kept_every() const { return kept_every_; }
  /// The current displacement (mm, 3 per vertex).
  const Eigen::VectorXd& displacement_mm() const { return displacement_mm_; }
  /// The vertices a grab captured (empty for a press).
  const std::vector<std::int32_t>& captured_vertices() const { return captured_; }
  std::uint64_t steps() const { return steps_; }
  /// Co-rotational: the last step's equilibrium solve, and how many steps ended short of
  /// the tolerance (their iterations spent; the next step goes on from there).
  const engine::fem::EquilibriumReport& last_equilibrium() const { return last_equilibrium_; }
  std::uint64_t unconverged_steps() const { return unconverged_steps_; }
  /// The model the FEM steps now: the run's, or the last remesh taken over.
  const FemModel& model() const { return *model_; }
  /// The remeshes taken over, in order (frames with mesh = k + 1 are the k-th's).
  const std::vector<std::unique_ptr<FemRemesh>>& remeshes() const { return remeshes_; }
  /// Label changes the run ended before taking over (a realtime build still running, or
  /// due after the last FEM step).
  std::size_t label_changes_not_taken() const { return changes_.size() - next_change_; }
  /// Per-vertex classes of the current model at the end: fixed, free, or constrained.
  std::vector<engine::fem::VertexClass> vertex_classes() const;
  /// The FEM's datasets for the run's first mesh: fem/displacement_mm (steps x vertices x
  /// 3), fem/step_tick, fem/step_time_s (from the tick and `rate_hz`, starting at `t0_s`),
  /// fem/vertex_class; for the k-th remesh the same under fem/remesh_k/, with its mesh as
  /// fem/remesh_k/mesh (haptics/mesh_file.h); the remeshes' ticks and build times as
  /// fem/remesh_change_tick, fem/remesh_taken_tick and timing/fem_remesh_build_s.
  void write_session(SessionWriter& session, double t0_s, double rate_hz) const;

 private:
  // The free vertices of the current model within the tool radius of the initial device
  // position, nearest first, at most kMaxContactVertices, sorted; and the nearest's distance.
  std::vector<std::int32_t> capture(double& nearest_mm) const;
  // Lockstep: builds a due change now; realtime: starts its build, and takes over one that
  // finished. True when the model changed.
  bool run_label_changes(std::int64_t tick);
  // Makes `remesh` the current model: the displacement carried over, the grab's vertices
  // captured again, the co-rotational solver replaced.
  void take_over(std::unique_ptr<FemRemesh> remesh, std::int64_t tick);
  // One FEM step for the device at `device_mm` whose tick left the proxy at `proxy_mm`
  // (the press normals' centre), the step's frame recorded for `tick`.
  void fem_step(const Vec3d& device_mm, const Vec3d& proxy_mm, std::int64_t tick);
  // Co-rotational: the equilibrium for `loads_n` (a grab's captured vertices held at the
  // offset of the proxy at `proxy_mm`, their loads replaced by what holds them there).
  Eigen::VectorXd corotational_step(const Vec3d& proxy_mm, Eigen::VectorXd& loads_n);
  // Appends `step` to frames_ (the last one stays only if kept), thinning them to every
  // other kept step while they are over the budget.
  void keep_step(FemFrame step);
  // The contact forces (N, all DOFs) the snapshot gives at `device_mm` (normals from
  // `proxy_hint_mm`), and the proxy.
  Eigen::VectorXd contact_loads(const ContactSnapshot& snapshot, const Vec3d& device_mm,
                                const Vec3d& proxy_hint_mm, Vec3d& proxy_mm);
  // K_FF^-1 (or the warped one) of a free-DOF vector.
  Eigen::VectorXd solve_free(const Eigen::VectorXd& rhs) const;
  // The next snapshot for the proxy at `proxy_mm` with loads `loads_n`.
  void make_snapshot(const Vec3d& proxy_mm, const Eigen::VectorXd& loads_n, ContactSnapshot& out);

  const FemModel* model_;        // the run's, or remeshes_.back()'s
  const FemModel* first_model_;  // the run's
  FemHandoff& handoff_;
  Vec3d initial_device_mm_;
  std::vector<LabelChange> changes_;
  std::size_t next_change_ = 0;
  std::vector<std::unique_ptr<FemRemesh>> remeshes_;
  bool realtime_ = false;
  // Realtime: the build of changes_[next_change_] on a thread of its own. rebuild_done_
  // (release) publishes rebuilt_ or rebuild_failure_ to the FEM thread.
  std::thread rebuild_thread_;
  std::atomic<bool> rebuild_done_{false};
  std::unique_ptr<FemRemesh> rebuilt_;
  std::exception_ptr rebuild_failure_;
  std::unique_ptr<engine::fem::CorotationalFem> corotational_;
  engine::fem::EquilibriumReport last_equilibrium_;
  std::uint64_t unconverged_steps_ = 0;
  Eigen::VectorXd displacement_mm_;
  ContactSnapshot current_;  // what was published last (the FEM thread's copy)
  PressScratch scratch_;
  std::vector<std::int32_t> captured_;
  std::vector<std::vector<std::int32_t>> captured_of_;  // on each earlier mesh
  // Grab: W^-1 of the captured vertices and their forces at the last step.
  Eigen::MatrixXd grab_w_inverse_;
  Eigen::VectorXd grab_vertex_forces_n_;
  std::vector<FemFrame> frames_;
  std::uint64_t kept_every_ = 1;
  std::size_t kept_bytes_ = 0;  // the displacements in frames_
  std::uint64_t steps_ = 0;
  std::exception_ptr failure_;  // realtime: what stopped the FEM thread's steps
};

}  // namespace hapvox::haptics
