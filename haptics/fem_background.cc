// The proxy-FEM model's background stage (haptics/fem_model.h): the FEM step, the snapshot
// it publishes, and its lockstep and realtime schedules.

#include <pthread.h>
#include <sys/resource.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <iterator>
#include <thread>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/fem/contact_compliance.h"
#include "haptics/fem_model.h"
#include "haptics/hdf5_id.h"
#include "haptics/mesh_file.h"
#include "haptics/scheduler.h"

namespace hapvox::haptics {
namespace {

using Clock = std::chrono::steady_clock;
using engine::fem::VertexClass;

Vec3d vertex_of(const Eigen::VectorXd& u, std::int32_t v) {
  return Vec3d(u(3 * v), u(3 * v + 1), u(3 * v + 2));
}

}  // namespace

FemBackgroundStage::FemBackgroundStage(const FemModel& model, FemHandoff& handoff,
                                       const Vec3d& initial_device_mm)
    : model_(&model),
      first_model_(&model),
      handoff_(handoff),
      initial_device_mm_(initial_device_mm) {
  const FemOptions& o = model_->options();
  if (o.solver == FemSolver::kCorotational) {
    corotational_ = std::make_unique<engine::fem::CorotationalFem>(
        model_->mesh(), model_->proxy().materials, model_->fixed_dofs(), o.corotational);
  }
  if (o.interaction == FemInteraction::kGrab) {
    double nearest_mm = INFINITY;
    captured_ = capture(nearest_mm);
    if (captured_.empty()) {
      char where[160];
      std::snprintf(where, sizeof where,
                    "nothing to grab within %g mm of (%g, %g, %g) mm (the nearest free vertex "
                    "is %g mm away)",
                    o.tool_radius_mm, initial_device_mm.x(), initial_device_mm.y(),
                    initial_device_mm.z(), nearest_mm);
      throw InputError("grab", where);
    }
  }
}

FemBackgroundStage::~FemBackgroundStage() {
  if (rebuild_thread_.joinable()) rebuild_thread_.join();
}

std::vector<std::int32_t> FemBackgroundStage::capture(double& nearest_mm) const {
  // The free vertices within the capture radius, nearest first (ties by index).
  std::vector<std::pair<double, std::int32_t>> near;
  nearest_mm = INFINITY;
  for (const std::int32_t v : model_->free_vertices()) {
    const double d = (model_->mesh().rest_mm.col(v) - initial_device_mm_).norm();
    nearest_mm = std::min(nearest_mm, d);
    if (d <= model_->options().tool_radius_mm) near.emplace_back(d, v);
  }
  std::sort(near.begin(), near.end());
  near.resize(std::min<std::size_t>(near.size(), kMaxContactVertices));
  std::vector<std::int32_t> captured;
  for (const auto& [d, v] : near) captured.push_back(v);
  std::sort(captured.begin(), captured.end());
  return captured;
}

void FemBackgroundStage::set_label_changes(std::vector<LabelChange> changes) {
  HAPVOX_CHECK(
      std::is_sorted(changes.begin(), changes.end(),
                     [](const LabelChange& a, const LabelChange& b) { return a.tick < b.tick; }));
  changes_ = std::move(changes);
  next_change_ = 0;
}

bool FemBackgroundStage::run_label_changes(std::int64_t tick) {
  if (next_change_ >= changes_.size()) return false;
  const LabelChange& change = changes_[next_change_];
  if (!realtime_) {
    if (tick < change.tick) return false;
    take_over(build_remesh(change, *model_), tick);
    return true;
  }
  if (!rebuild_thread_.joinable()) {
    if (tick < change.tick) return false;
    rebuild_done_.store(false, std::memory_order_relaxed);
    // Built against the current model, which stays current until this build is taken over.
    rebuild_thread_ = std::thread([this, &change, previous = model_] {
      pthread_setname_np(pthread_self(), "hapvox-remesh");
      setpriority(PRIO_PROCESS, 0, 10);  // this thread only (Linux): below the FEM thread
      try {
        rebuilt_ = build_remesh(change, *previous);
      } catch (...) {
        rebuild_failure_ = std::current_exception();
      }
      rebuild_done_.store(true, std::memory_order_release);
    });
    return false;
  }
  if (!rebuild_done_.load(std::memory_order_acquire)) return false;
  rebuild_thread_.join();
  if (rebuild_failure_ != nullptr) std::rethrow_exception(rebuild_failure_);
  take_over(std::move(rebuilt_), tick);
  return true;
}

void FemBackgroundStage::take_over(std::unique_ptr<FemRemesh> remesh, std::int64_t tick) {
  HAPVOX_CHECK_EQ(remesh->from_previous.size(),
                  static_cast<std::size_t>(remesh->model->mesh().vertex_count()));
  displacement_mm_ = engine::fem::interpolate_vector_field(remesh->from_previous, displacement_mm_);
  for (const int dof : remesh->model->fixed_dofs()) {
    displacement_mm_(dof) = remesh->model->prescribed_mm()(dof);
  }
  captured_of_.push_back(std::move(captured_));  // a press's is empty
  captured_.clear();
  // Owned by remeshes_ before it is current, so an exception below leaves no dangling model_.
  remeshes_.push_back(std::move(remesh));
  FemRemesh& taken = *remeshes_.back();
  model_ = taken.model.get();
  corotational_ = std::move(taken.corotational);
  if (model_->options().interaction == FemInteraction::kGrab) {
    // Captured again at rest, as at the start: the vertices a newly fixed label took are
    // let go (none left: the grab holds nothing).
    double nearest_mm = 0.0;
    captured_ = capture(nearest_mm);
  }
  // The snapshot's vertices are the old mesh's: none may be taken for the new one's.
  current_.count = 0;
  scratch_ = PressScratch{};
  ++next_change_;
  taken.taken_tick = tick;
  taken.captured_vertices = static_cast<int>(captured_.size());
}

std::vector<VertexClass> FemBackgroundStage::vertex_classes() const {
  std::vector<VertexClass> classes = model_->proxy().vertex_classes;
  for (const std::int32_t v : captured_) classes[v] = VertexClass::kConstrained;
  return classes;
}

Eigen::VectorXd FemBackgroundStage::solve_free(const Eigen::VectorXd& rhs) const {
  return corotational_ != nullptr ? corotational_->solve_free(rhs)
                                  : model_->linear().solve_free(rhs);
}

Eigen::VectorXd FemBackgroundStage::contact_loads(const ContactSnapshot& snapshot,
                                                  const Vec3d& device_mm,
                                                  const Vec3d& proxy_hint_mm, Vec3d& proxy_mm) {
  const FemOptions& o = model_->options();
  Eigen::VectorXd loads = Eigen::VectorXd::Zero(3 * model_->mesh().vertex_count());
  if (o.interaction == FemInteraction::kPress) {
    const ContactSolve solve = solve_press(snapshot, device_mm, proxy_hint_mm, o.tool_radius_mm,
                                           o.coupling_n_per_mm, scratch_);
    proxy_mm = solve.proxy_mm;
    for (int i = 0; i < snapshot.count; ++i) {
      loads.segment<3>(3 * snapshot.vertices[i]) += solve.lambda_n[i] * solve.normal[i];
    }
    return loads;
  }
  const ContactSolve solve = solve_grab(snapshot, device_mm, o.coupling_n_per_mm);
  proxy_mm = solve.proxy_mm;
  if (!snapshot.grabbing) return loads;
  // f = f_cur + W^-1 (1 (x) (d - d_cur)): the captured vertices all displaced by d.
  const Vec3d step_mm = proxy_mm - snapshot.anchor_mm - snapshot.grab_offset_mm;
  Eigen::VectorXd shift(3 * snapshot.count);
  for (int i = 0; i < snapshot.count; ++i) shift.segment<3>(3 * i) = step_mm;
  const Eigen::VectorXd f = grab_vertex_forces_n_ + grab_w_inverse_ * shift;
  for (int i = 0; i < snapshot.count; ++i) {
    loads.segment<3>(3 * snapshot.vertices[i]) = f.segment<3>(3 * i);
  }
  return loads;
}

void FemBackgroundStage::make_snapshot(const Vec3d& proxy_mm, const Eigen::VectorXd& loads_n,
                                       ContactSnapshot& out) {
  const FemOptions& o = model_->options();
  const engine::fem::TetMesh& mesh = model_->mesh();
  const engine::fem::DofPartition& partition = model_->linear().partition();
  std::vector<std::int32_t> vertices;
  if (o.interaction == FemInteraction::kGrab) {
    vertices = captured_;
  } else {
    // Vertices in contact stay; then the nearest to the tool's surface within the margin.
    std::vector<std::pair<double, std::int32_t>> near;
    for (const std::int32_t v : model_->surface_vertices()) {
      const Vec3d x = mesh.rest_mm.col(v) + vertex_of(displacement_mm_, v);
      const double gap = (x - proxy_mm).norm() - o.tool_radius_mm;
      const bool loaded = loads_n.segment<3>(3 * v).squaredNorm() > 0.0;
      if (loaded || gap <= o.candidate_margin_mm) near.emplace_back(loaded ? -INFINITY : gap, v);
    }
    std::sort(near.begin(), near.end());
    near.resize(std::min<std::size_t>(near.size(), kMaxContactVertices));
    for (const auto& [gap, v] : near) vertices.push_back(v);
    std::sort(vertices.begin(), vertices.end());
  }
  const int n = static_cast<int>(vertices.size());
  // Linear statics: K never changes, so neither does W of an unchanged vertex set.
  const bool same_set = corotational_ == nullptr && steps_ > 0 && current_.count == n &&
                        std::equal(vertices.begin(), vertices.end(), current_.vertices.begin());
  out.count = n;
  if (same_set) {
    out.w_mm_per_n = current_.w_mm_per_n;
  } else {
    out.w_mm_per_n.setZero();
    engine::fem::condensed_compliance(
        partition, vertices, [this](const Eigen::VectorXd& rhs) { return solve_free(rhs); },
        out.w_mm_per_n.topLeftCorner(3 * n, 3 * n));
  }
  // Symmetric to the last bit, so that the force thread's M is.
  const auto w = out.w_mm_per_n.topLeftCorner(3 * n, 3 * n);
  const Eigen::MatrixXd symmetric = 0.5 * (w + w.transpose());
  out.w_mm_per_n.topLeftCorner(3 * n, 3 * n) = symmetric;
  Eigen::VectorXd f(3 * n);
  for (int i = 0; i < n; ++i) {
    out.vertices[i] = vertices[i];
    f.segment<3>(3 * i) = loads_n.segment<3>(3 * vertices[i]);
  }
  const Eigen::VectorXd w_f = symmetric * f;
  for (int i = 0; i < n; ++i) {
    // Linear statics: with no other load the base is the rest position, exactly.
    // Co-rotational: the linearisation about the current state.
    out.base_mm[i] = corotational_ == nullptr
                         ? Vec3d(mesh.rest_mm.col(vertices[i]))
                         : Vec3d(mesh.rest_mm.col(vertices[i]) +
                                 vertex_of(displacement_mm_, vertices[i]) - w_f.segment<3>(3 * i));
  }
  out.grabbing = o.interaction == FemInteraction::kGrab && n > 0;
  if (out.grabbing) {
    if (same_set) {
      // W is the last step's, bit for bit, and so are W^-1 and K_g.
      out.grab_stiffness_n_per_mm = current_.grab_stiffness_n_per_mm;
    } else {
      grab_w_inverse_ = symmetric.llt().solve(Eigen::MatrixXd::Identity(3 * n, 3 * n));
      grab_w_inverse_ = 0.5 * (grab_w_inverse_ + grab_w_inverse_.transpose()).eval();
      out.grab_stiffness_n_per_mm.setZero();
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          out.grab_stiffness_n_per_mm += grab_w_inverse_.block<3, 3>(3 * i, 3 * j);
        }
      }
    }
    if (steps_ == 0) out.anchor_mm = proxy_mm;
    out.grab_offset_mm = proxy_mm - out.anchor_mm;
    // Co-rotational: the loads corrected by what still separates the captured vertices from
    // the offset after the step, so the grab stays displacement-controlled as rotations change.
    Eigen::VectorXd gap_mm(3 * n);
    for (int i = 0; i < n; ++i) {
      gap_mm.segment<3>(3 * i) = out.grab_offset_mm - vertex_of(displacement_mm_, vertices[i]);
    }
    grab_vertex_forces_n_ = f + grab_w_inverse_ * gap_mm;
    out.grab_force_n.setZero();
    for (int i = 0; i < n; ++i) out.grab_force_n += grab_vertex_forces_n_.segment<3>(3 * i);
    if (corotational_ == nullptr) {
      // Linear: the forces that hold every captured vertex at the offset, exactly.
      Eigen::VectorXd shift(3 * n);
      for (int i = 0; i < n; ++i) shift.segment<3>(3 * i) = out.grab_offset_mm;
      grab_vertex_forces_n_ = grab_w_inverse_ * shift;
      out.grab_force_n = out.grab_stiffness_n_per_mm * out.grab_offset_mm;
    }
  }
}

void FemBackgroundStage::fem_step(const Vec3d& device_mm, const Vec3d& tick_proxy_mm,
                                  std::int64_t tick) {
  Vec3d proxy_mm = device_mm;
  Eigen::VectorXd loads = Eigen::VectorXd::Zero(3 * model_->mesh().vertex_count());
  if (steps_ > 0) loads = contact_loads(current_, device_mm, tick_proxy_mm, proxy_mm);
  if (steps_ > 0 && run_label_changes(tick)) {
    // The loads found on the old mesh's snapshot belong to its vertices: solve the contact
    // again on a snapshot of the new mesh, about the proxy found on the old one.
    // The loads that hold the carried-over shape: its elastic forces (co-rotational; the
    // linear snapshot needs none: its bases are the rest positions and a grab's forces
    // follow from its offset).
    Eigen::VectorXd held_n = Eigen::VectorXd::Zero(3 * model_->mesh().vertex_count());
    if (corotational_ != nullptr) {
      held_n = corotational_->elastic_forces_n(displacement_mm_);
      for (const int dof : model_->fixed_dofs()) held_n(dof) = 0.0;
    }
    auto provisional = std::make_unique<ContactSnapshot>();  // 73 kB: not on the stack
    provisional->anchor_mm = current_.anchor_mm;
    provisional->fem_step = ~std::uint64_t{0} - 1;
    make_snapshot(proxy_mm, held_n, *provisional);
    const Vec3d old_proxy_mm = proxy_mm;
    loads = contact_loads(*provisional, device_mm, old_proxy_mm, proxy_mm);
  }
  const int dofs = 3 * model_->mesh().vertex_count();
  const Eigen::VectorXd& prescribed = model_->prescribed_mm();
  if (corotational_ != nullptr) {
    displacement_mm_ = corotational_step(proxy_mm, loads);
  } else {
    displacement_mm_ = model_->linear().solve_mm(loads, prescribed);
  }
  ContactSnapshot& next = handoff_.snapshots.write_slot();
  next.anchor_mm = current_.anchor_mm;
  make_snapshot(proxy_mm, loads, next);
  next.fem_step = ++steps_;
  current_ = next;
  handoff_.snapshots.publish();
  keep_step(FemFrame{tick,
                     std::vector<double>(displacement_mm_.data(), displacement_mm_.data() + dofs),
                     static_cast<int>(remeshes_.size()), steps_ - 1});
}

Eigen::VectorXd FemBackgroundStage::corotational_step(const Vec3d& proxy_mm,
                                                      Eigen::VectorXd& loads_n) {
  const FemOptions& o = model_->options();
  // A grab holds its captured vertices at the proxy's offset from where it took them (the
  // first step: where they are), and the snapshot's forces are what holds them there.
  std::vector<int> held_dofs;
  std::vector<double> held_mm;
  if (o.interaction == FemInteraction::kGrab) {
    const Vec3d offset_mm = steps_ == 0 ? Vec3d::Zero() : Vec3d(proxy_mm - current_.anchor_mm);
    for (const std::int32_t v : captured_) {
      for (int axis = 0; axis < 3; ++axis) {
        held_dofs.push_back(engine::fem::dof_index(v, axis));
        held_mm.push_back(offset_mm(axis));
      }
    }
  }
  Eigen::VectorXd held_n;
  Eigen::VectorXd u =
      corotational_->equilibrium_mm(displacement_mm_, loads_n, model_->prescribed_mm(), held_dofs,
                                    held_mm, o.equilibrium, &last_equilibrium_, &held_n);
  for (std::size_t h = 0; h < held_dofs.size(); ++h) loads_n(held_dofs[h]) = held_n(h);
  if (!last_equilibrium_.converged) ++unconverged_steps_;
  return u;
}

void FemBackgroundStage::keep_step(FemFrame step) {
  auto bytes = [](const FemFrame& frame) { return frame.displacement_mm.size() * sizeof(double); };
  // The last step made is kept as the latest (the renderer's and the session's end), and
  // stays once a later one comes only if it is one of the kept.
  if (!frames_.empty() && frames_.back().step % kept_every_ != 0) {
    kept_bytes_ -= bytes(frames_.back());
    frames_.pop_back();
  }
  kept_bytes_ += bytes(step);
  frames_.push_back(std::move(step));
  const double budget_bytes = model_->options().kept_steps_mb * 1e6;
  while (static_cast<double>(kept_bytes_) > budget_bytes && frames_.size() > 2) {
    kept_every_ *= 2;
    const auto last = std::prev(frames_.end());
    const auto end = std::remove_if(frames_.begin(), last, [&](const FemFrame& frame) {
      return frame.step % kept_every_ != 0;
    });
    frames_.erase(end, last);
    kept_bytes_ = 0;
    for (const FemFrame& frame : frames_) kept_bytes_ += bytes(frame);
  }
}

void FemBackgroundStage::begin() {
  displacement_mm_ = Eigen::VectorXd::Zero(3 * model_->mesh().vertex_count());
  frames_.clear();
  kept_every_ = 1;
  kept_bytes_ = 0;
  steps_ = 0;
  current_ = ContactSnapshot{};
  fem_step(initial_device_mm_, initial_device_mm_, 0);
}

void FemBackgroundStage::run_lockstep_tick(std::size_t tick, TickRecord& row,
                                           const LockstepRender* render) {
  if ((tick + 1) % model_->options().fem_every_ticks == 0) {
    fem_step(row.tool_position_mm, row.tool_position_mm + row.displacement_mm,
             static_cast<std::int64_t>(tick));
    if (render != nullptr && render->mesh_changed) {
      const FemFrame& step = frames_.back();
      render->mesh_changed(step.tick, model_->mesh(), step.mesh, step.displacement_mm);
    }
  }
}

void FemBackgroundStage::run_realtime(const std::atomic<bool>& force_done, Clock::time_point start,
                                      RenderFeed* feed, BackgroundTiming& timing) {
  realtime_ = true;
  const double cpu_start = thread_cpu_s();
  const auto period = std::chrono::nanoseconds(
      static_cast<std::int64_t>(std::llround(1e9 / model_->options().fem_rate_hz)));
  auto next = Clock::now();
  std::int64_t last_tick = -1;
  while (!force_done.load(std::memory_order_acquire)) {
    const RenderToolState device = handoff_.device.read();
    if (device.tick >= 0 && device.tick != last_tick && failure_ == nullptr) {
      const auto begin = Clock::now();
      try {
        fem_step(device.center_mm, device.center_mm + device.displacement_mm, device.tick);
        if (feed != nullptr) {  // the render thread's copy (allocates in the first few only)
          MeshDisplacement& out = feed->mesh.write_slot();
          out.tick = frames_.back().tick;
          out.mesh = &model_->mesh();
          out.mesh_index = frames_.back().mesh;
          out.displacement_mm = frames_.back().displacement_mm;
          feed->mesh.publish();
        }
      } catch (...) {
        // The force thread keeps the last snapshot; finish() reports the failure.
        failure_ = std::current_exception();
      }
      last_tick = device.tick;
      timing.slice_start_ns.push_back(
          std::chrono::duration_cast<std::chrono::nanoseconds>(begin - start).count());
      timing.slice_ns.push_back(
          std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - begin).count());
    }
    next += period;
    const auto now = Clock::now();
    if (next < now) next = now;  // late: no burst of steps to catch up
    // Sleep in short pieces so that the end of the run is noticed within a millisecond.
    while (Clock::now() < next && !force_done.load(std::memory_order_acquire)) {
      std::this_thread::sleep_until(std::min(next, Clock::now() + std::chrono::milliseconds(1)));
    }
  }
  timing.cpu_s = thread_cpu_s() - cpu_start;
}

SculptSummary FemBackgroundStage::finish(const LockstepRender*, RenderFeed*,
                                         const std::atomic<bool>*) {
  if (rebuild_thread_.joinable()) rebuild_thread_.join();  // a build the run ended before
  if (failure_ != nullptr) std::rethrow_exception(failure_);
  SculptSummary summary;
  summary.settled = true;
  return summary;
}

void FemBackgroundStage::write_session(SessionWriter& session, double t0_s, double rate_hz) const {
  // One group per mesh: the run's in fem/, the k-th remesh's in fem/remesh_k/.
  for (std::size_t mesh = 0; mesh <= remeshes_.size(); ++mesh) {
    const FemModel& model = mesh == 0 ? *first_model_ : *remeshes_[mesh - 1]->model;
    const std::string group = mesh == 0 ? "fem/" : "fem/remesh_" + std::to_string(mesh) + "/";
    const std::size_t vertices = static_cast<std::size_t>(model.mesh().vertex_count());
    std::vector<double> displacement;
    std::vector<std::int64_t> ticks;
    std::vector<double> times;
    for (const FemFrame& frame : frames_) {
      if (frame.mesh != static_cast<int>(mesh)) continue;
      displacement.insert(displacement.end(), frame.displacement_mm.begin(),
                          frame.displacement_mm.end());
      ticks.push_back(frame.tick);
      times.push_back(t0_s + static_cast<double>(frame.tick) / rate_hz);
    }
    session.write_array(group + "displacement_mm", displacement, {ticks.size(), vertices, 3}, "mm");
    session.write_array(group + "step_tick", ticks, nullptr);
    session.write_array(group + "step_time_s", times, {times.size()}, "s");
    std::vector<std::int64_t> classes;
    for (const VertexClass c : model.proxy().vertex_classes) {
      classes.push_back(static_cast<std::int64_t>(c));
    }
    if (mesh == remeshes_.size()) {  // the current mesh: the grab's vertices constrained
      for (const std::int32_t v : captured_) {
        classes[v] = static_cast<std::int64_t>(VertexClass::kConstrained);
      }
    } else {  // an earlier mesh: the vertices the grab held on it
      for (const std::int32_t v : captured_of_[mesh]) {
        classes[v] = static_cast<std::int64_t>(VertexClass::kConstrained);
      }
    }
    session.write_array(group + "vertex_class", classes, nullptr);
    if (mesh > 0) {
      const H5Id handle(H5Gopen2(session.file_handle(), group.c_str(), H5P_DEFAULT), H5Gclose);
      HAPVOX_CHECK(handle.valid());
      write_proxy_mesh(handle.get(), model.proxy());
    }
  }
  std::vector<std::int64_t> change_ticks;
  std::vector<std::int64_t> taken_ticks;
  std::vector<double> build_s;
  for (const auto& remesh : remeshes_) {
    change_ticks.push_back(remesh->change_tick);
    taken_ticks.push_back(remesh->taken_tick);
    build_s.push_back(remesh->build_s);
  }
  if (!remeshes_.empty()) {
    session.write_array("fem/remesh_change_tick", change_ticks, nullptr);
    session.write_array("fem/remesh_taken_tick", taken_ticks, nullptr);
    session.write_array("timing/fem_remesh_build_s", build_s, {build_s.size()}, "s");
  }
  session.set_attribute("fem_steps", static_cast<std::int64_t>(steps_));
  session.set_attribute("fem_steps_kept_every", static_cast<std::int64_t>(kept_every_));
  session.set_attribute("fem_remeshes", static_cast<std::int64_t>(remeshes_.size()));
  session.set_attribute("fem_label_changes_not_taken",
                        static_cast<std::int64_t>(label_changes_not_taken()));
  session.set_attribute("grabbed_vertices", static_cast<std::int64_t>(captured_.size()));
}

}  // namespace hapvox::haptics
