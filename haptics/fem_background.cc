// The proxy-FEM model's background stage (haptics/fem_model.h): the FEM step, the snapshot
// it publishes, and its lockstep and realtime schedules.

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <thread>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/fem/contact_compliance.h"
#include "haptics/fem_model.h"
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
    : model_(model), handoff_(handoff), initial_device_mm_(initial_device_mm) {
  const FemOptions& o = model_.options();
  if (o.solver == FemSolver::kCorotational) {
    corotational_ = std::make_unique<engine::fem::CorotationalFem>(
        model_.mesh(), model_.proxy().materials, model_.fixed_dofs(), o.corotational);
  }
  if (o.interaction == FemInteraction::kGrab) {
    // The free vertices within the capture radius, nearest first (ties by index).
    std::vector<std::pair<double, std::int32_t>> near;
    double nearest_mm = INFINITY;
    for (const std::int32_t v : model_.free_vertices()) {
      const double d = (model_.mesh().rest_mm.col(v) - initial_device_mm).norm();
      nearest_mm = std::min(nearest_mm, d);
      if (d <= o.tool_radius_mm) near.emplace_back(d, v);
    }
    if (near.empty()) {
      char where[160];
      std::snprintf(where, sizeof where,
                    "nothing to grab within %g mm of (%g, %g, %g) mm (the nearest free vertex "
                    "is %g mm away)",
                    o.tool_radius_mm, initial_device_mm.x(), initial_device_mm.y(),
                    initial_device_mm.z(), nearest_mm);
      throw InputError("grab", where);
    }
    std::sort(near.begin(), near.end());
    near.resize(std::min<std::size_t>(near.size(), kMaxContactVertices));
    for (const auto& [d, v] : near) captured_.push_back(v);
    std::sort(captured_.begin(), captured_.end());
  }
}

FemBackgroundStage::~FemBackgroundStage() = default;

std::vector<VertexClass> FemBackgroundStage::vertex_classes() const {
  std::vector<VertexClass> classes = model_.proxy().vertex_classes;
  for (const std::int32_t v : captured_) classes[v] = VertexClass::kConstrained;
  return classes;
}

Eigen::VectorXd FemBackgroundStage::solve_free(const Eigen::VectorXd& rhs) const {
  return corotational_ != nullptr ? corotational_->solve_free(rhs)
                                  : model_.linear().solve_free(rhs);
}

Eigen::VectorXd FemBackgroundStage::contact_loads(const ContactSnapshot& snapshot,
                                                  const Vec3d& device_mm,
                                                  const Vec3d& proxy_hint_mm, Vec3d& proxy_mm) {
  const FemOptions& o = model_.options();
  Eigen::VectorXd loads = Eigen::VectorXd::Zero(3 * model_.mesh().vertex_count());
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
  const FemOptions& o = model_.options();
  const engine::fem::TetMesh& mesh = model_.mesh();
  const engine::fem::DofPartition& partition = model_.linear().partition();
  std::vector<std::int32_t> vertices;
  if (o.interaction == FemInteraction::kGrab) {
    vertices = captured_;
  } else {
    // Vertices in contact stay; then the nearest to the tool's surface within the margin.
    std::vector<std::pair<double, std::int32_t>> near;
    for (const std::int32_t v : model_.surface_vertices()) {
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
    grab_w_inverse_ = symmetric.llt().solve(Eigen::MatrixXd::Identity(3 * n, 3 * n));
    grab_w_inverse_ = 0.5 * (grab_w_inverse_ + grab_w_inverse_.transpose()).eval();
    out.grab_stiffness_n_per_mm.setZero();
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        out.grab_stiffness_n_per_mm += grab_w_inverse_.block<3, 3>(3 * i, 3 * j);
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
  const int dofs = 3 * model_.mesh().vertex_count();
  Vec3d proxy_mm = device_mm;
  Eigen::VectorXd loads = Eigen::VectorXd::Zero(dofs);
  if (steps_ > 0) loads = contact_loads(current_, device_mm, tick_proxy_mm, proxy_mm);
  const Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(dofs);
  if (corotational_ != nullptr) {
    displacement_mm_ = corotational_->step_mm(displacement_mm_, loads, prescribed);
  } else {
    displacement_mm_ = model_.linear().solve_mm(loads, prescribed);
  }
  ContactSnapshot& next = handoff_.snapshots.write_slot();
  next.anchor_mm = current_.anchor_mm;
  make_snapshot(proxy_mm, loads, next);
  next.fem_step = ++steps_;
  current_ = next;
  handoff_.snapshots.publish();
  frames_.push_back(
      FemFrame{tick, std::vector<double>(displacement_mm_.data(), displacement_mm_.data() + dofs)});
}

void FemBackgroundStage::begin() {
  displacement_mm_ = Eigen::VectorXd::Zero(3 * model_.mesh().vertex_count());
  frames_.clear();
  steps_ = 0;
  current_ = ContactSnapshot{};
  fem_step(initial_device_mm_, initial_device_mm_, 0);
}

void FemBackgroundStage::run_lockstep_tick(std::size_t tick, TickRecord& row,
                                           const LockstepRender*) {
  if ((tick + 1) % model_.options().fem_every_ticks == 0) {
    fem_step(row.tool_position_mm, row.tool_position_mm + row.displacement_mm,
             static_cast<std::int64_t>(tick));
  }
}

void FemBackgroundStage::run_realtime(const std::atomic<bool>& force_done, Clock::time_point start,
                                      RenderFeed*, BackgroundTiming& timing) {
  const double cpu_start = thread_cpu_s();
  const auto period = std::chrono::nanoseconds(
      static_cast<std::int64_t>(std::llround(1e9 / model_.options().fem_rate_hz)));
  auto next = Clock::now();
  std::int64_t last_tick = -1;
  while (!force_done.load(std::memory_order_acquire)) {
    const RenderToolState device = handoff_.device.read();
    if (device.tick >= 0 && device.tick != last_tick && failure_ == nullptr) {
      const auto begin = Clock::now();
      try {
        fem_step(device.center_mm, device.center_mm + device.displacement_mm, device.tick);
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
  if (failure_ != nullptr) std::rethrow_exception(failure_);
  SculptSummary summary;
  summary.settled = true;
  return summary;
}

void FemBackgroundStage::write_session(SessionWriter& session, double t0_s, double rate_hz) const {
  const std::size_t vertices = static_cast<std::size_t>(model_.mesh().vertex_count());
  std::vector<double> displacement;
  displacement.reserve(frames_.size() * 3 * vertices);
  std::vector<std::int64_t> ticks;
  std::vector<double> times;
  for (const FemFrame& frame : frames_) {
    displacement.insert(displacement.end(), frame.displacement_mm.begin(),
                        frame.displacement_mm.end());
    ticks.push_back(frame.tick);
    times.push_back(t0_s + static_cast<double>(frame.tick) / rate_hz);
  }
  session.write_array("fem/displacement_mm", displacement, {frames_.size(), vertices, 3}, "mm");
  session.write_array("fem/step_tick", ticks, nullptr);
  session.write_array("fem/step_time_s", times, {times.size()}, "s");
  std::vector<std::int64_t> classes;
  for (const VertexClass c : vertex_classes()) classes.push_back(static_cast<std::int64_t>(c));
  session.write_array("fem/vertex_class", classes, nullptr);
  session.set_attribute("fem_steps", static_cast<std::int64_t>(steps_));
  session.set_attribute("grabbed_vertices", static_cast<std::int64_t>(captured_.size()));
}

}  // namespace hapvox::haptics
