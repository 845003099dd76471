#include "engine/relax.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "engine/check.h"

namespace hapvox::engine {

std::int32_t normal_density_units(double normal_density) {
  HAPVOX_CHECK(normal_density > 0.0 && normal_density <= 1.0);
  return std::max<std::int32_t>(
      1, static_cast<std::int32_t>(std::lround(normal_density * kNormalDensityUnits)));
}

MassGrid::MassGrid(const DensityField& field, const RelaxOptions& options)
    : grid_(openvdb::Int32Grid::create(0)),
      accessor_(grid_->getAccessor()),
      voxel_size_mm_(field.voxel_size_mm()),
      origin_mm_(field.origin_mm()),
      dims_(field.dims()),
      direction_(field.direction()),
      normal_units_(normal_density_units(options.normal_density)),
      threshold_units_(static_cast<std::int32_t>(
          std::floor(normal_units_ * (1.0 + std::max(0.0, options.tolerance))))),
      rule_(options.rule),
      flow_visits_per_voxel_(options.flow_visits_per_voxel),
      skip_swept_voxels_(options.skip_swept_voxels) {
  HAPVOX_CHECK_GE(flow_visits_per_voxel_, std::size_t{1});
  for (auto it = field.grid().cbeginValueOn(); it; ++it) {
    const auto units = static_cast<std::int32_t>(std::lround(*it * kNormalDensityUnits));
    if (units <= 0) continue;
    if (it.isVoxelValue()) {
      accessor_.setValueOn(it.getCoord(), units);
    } else {
      openvdb::CoordBBox box;
      it.getBoundingBox(box);
      grid_->tree().fill(box, units, true);
    }
  }
  grid_->tree().voxelizeActiveTiles();
  accessor_.clear();
  // The flow's visited set, dense over the volume and a margin the clay may be pushed
  // into, allocated now rather than on the relaxation thread.
  openvdb::CoordBBox box(openvdb::Coord(0),
                         openvdb::Coord(dims_.x() - 1, dims_.y() - 1, dims_.z() - 1));
  box.expand(grid_->evalActiveVoxelBoundingBox());
  box.expand(kFlowMarginVoxels);
  flow_visited_.make_dense(box);
  flow_queue_.resize(kFlowQueueReserve);  // written once, so its pages are there
  flow_queue_.clear();
  grid_units_ = summed_mass_units();  // from here on every change goes through set()
}

std::int64_t MassGrid::summed_mass_units() const {
  std::int64_t sum = 0;
  for (auto it = grid_->cbeginValueOn(); it; ++it) {
    sum += static_cast<std::int64_t>(*it) * static_cast<std::int64_t>(it.getVoxelCount());
  }
  return sum + flowing_units();
}

void MassGrid::set(const openvdb::Coord& ijk, std::int32_t units) {
  HAPVOX_CHECK_GE(units, 0);
  grid_units_ += std::int64_t{units} - accessor_.getValue(ijk);
  if (units == 0) {
    accessor_.setValueOff(ijk, 0);
  } else {
    accessor_.setValueOn(ijk, units);
  }
  if (!listed_accessor_.isValueOn(ijk)) {
    listed_accessor_.setValueOn(ijk);
    changed_.push_back(ijk);
  }
}

void MassGrid::activate_if_over(const openvdb::Coord& ijk, std::int32_t units) {
  if (units > threshold_units_) queue_.push(Entry{units, ijk});
}

void MassGrid::relax_voxel(const openvdb::Coord& v, std::int32_t units) {
  const std::int64_t excess = static_cast<std::int64_t>(units) - normal_units_;
  if (excess <= 0) return;
  openvdb::Coord neighbours[26];
  std::int32_t values[26];
  int count = 0;
  std::int64_t sum = units;
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const openvdb::Coord n = v.offsetBy(dx, dy, dz);
        if (under_tool(n)) continue;
        if (rule_ == RelaxRule::kFlowToRoom && carved_accessor_.isValueOn(n)) continue;
        neighbours[count] = n;
        values[count] = accessor_.getValue(n);
        sum += values[count];
        ++count;
      }
    }
  }
  if (count == 0) {  // walled in by the tool: wait until it moves
    walled_in_.push_back(v);
    return;
  }
  const bool flow = rule_ == RelaxRule::kFlowToRoom;
  // Flowing excess never raises a receiver above the normal density: that is what keeps
  // the bulk from diffusing and lets the pool reach the surface in one search.
  const std::int64_t mean =
      flow ? std::min<std::int64_t>(sum / (count + 1), normal_units_) : sum / (count + 1);
  std::int64_t added[26] = {};
  std::int64_t given = 0;
  // Material first flows into material (neighbours holding some), and only what they
  // cannot take goes into empty voxels: clay spreads through itself before it grows
  // into the air, which keeps grooves open and surfaces free of haze.
  for (int pass = 0; pass < 2 && given < excess; ++pass) {
    std::int64_t room[26];
    std::int64_t total_room = 0;
    for (int n = 0; n < count; ++n) {
      const bool eligible = pass == 0 ? values[n] > 0 : values[n] == 0;
      room[n] = eligible ? std::max<std::int64_t>(0, mean - values[n] - added[n]) : 0;
      total_room += room[n];
    }
    const std::int64_t give = std::min(excess - given, total_room);
    if (give <= 0) continue;
    std::int64_t pass_given = 0;
    std::int64_t share[26];
    for (int n = 0; n < count; ++n) {
      share[n] = give * room[n] / total_room;
      pass_given += share[n];
    }
    for (int n = 0; n < count && pass_given < give; ++n) {
      if (share[n] < room[n]) {
        ++share[n];
        ++pass_given;
      }
    }
    HAPVOX_CHECK_EQ(pass_given, give);
    for (int n = 0; n < count; ++n) added[n] += share[n];
    given += give;
  }
  const std::int64_t rest = excess - given;
  if (flow) {
    if (rest > 0) {
      pool_units_ += rest;
      pool_sources_.push_back(v);
    }
  } else {
    // The paper: no room below the mean, so the rest is spread evenly and diffuses.
    for (int n = 0; n < count; ++n) added[n] += rest / count;
    for (int n = 0; n < rest % count; ++n) ++added[n];
  }
  set(v, normal_units_);
  for (int n = 0; n < count; ++n) {
    if (added[n] == 0) continue;
    const std::int64_t updated = values[n] + added[n];
    HAPVOX_CHECK_LE(updated, std::int64_t{INT32_MAX});
    set(neighbours[n], static_cast<std::int32_t>(updated));
    activate_if_over(neighbours[n], static_cast<std::int32_t>(updated));
  }
  work_.moved_units += static_cast<std::uint64_t>(excess);
}

std::size_t MassGrid::relax(std::size_t max_voxels) {
  const std::size_t max_visits = max_voxels > SIZE_MAX / flow_visits_per_voxel_
                                     ? SIZE_MAX
                                     : max_voxels * flow_visits_per_voxel_;
  // A search cut short by the last call's budget goes on first: its mass is outside the
  // grid until it lands.
  std::size_t visits = flow_active_ ? advance_flow(max_visits) : 0;
  const std::size_t max_stale =
      max_voxels > SIZE_MAX / kStalePopsPerVoxel ? SIZE_MAX : max_voxels * kStalePopsPerVoxel;
  std::size_t done = 0, stale = 0;
  while (done < max_voxels && stale < max_stale && !queue_.empty()) {
    const Entry top = queue_.top();
    queue_.pop();
    const std::int32_t current = accessor_.getValue(top.ijk);
    if (current != top.units || current <= threshold_units_) {
      ++stale;  // queued again since, or relaxed already
      continue;
    }
    relax_voxel(top.ijk, current);
    ++done;
  }
  // What no neighbour could take flows with what is left of the visits; while a search is
  // still in flight it waits for the next one.
  if (!flow_active_ && pool_units_ > 0 && visits < max_visits) {
    start_flow();
    visits += advance_flow(max_visits - visits);
  }
  work_.relaxed_voxels += done;
  work_.stale_pops += stale;
  return done + visits + stale;
}

void MassGrid::finish_flows() {
  while (flow_active_ || pool_units_ > 0) {
    if (!flow_active_) start_flow();
    advance_flow(SIZE_MAX);
  }
}

void MassGrid::start_flow() {
  // Breadth-first from all pool sources at once, 6-connected, through voxels holding
  // material (a filled empty voxel becomes material and the search goes on through it),
  // never through the tool. Deterministic: sources in relaxation order, neighbours in a
  // fixed order.
  HAPVOX_CHECK(!flow_active_ && pool_units_ > 0 && !pool_sources_.empty());
  flow_active_ = true;
  flow_units_ = pool_units_;
  pool_units_ = 0;
  flow_first_source_ = pool_sources_.front();
  flow_queue_.clear();
  flow_head_ = 0;
  for (const openvdb::Coord& ijk : pool_sources_) {
    if (flow_visited_.insert(ijk)) flow_queue_.push_back(ijk);
  }
  pool_sources_.clear();
}

std::size_t MassGrid::advance_flow(std::size_t max_steps) {
  static constexpr int kSteps[6][3] = {{0, 0, 1},  {0, 0, -1}, {1, 0, 0},
                                       {-1, 0, 0}, {0, 1, 0},  {0, -1, 0}};
  std::size_t steps = 0;
  while (flow_units_ > 0 && flow_head_ < flow_queue_.size() && steps < max_steps) {
    const openvdb::Coord u = flow_queue_[flow_head_++];
    ++steps;
    for (const auto& step : kSteps) {
      const openvdb::Coord n = u.offsetBy(step[0], step[1], step[2]);
      if (!flow_visited_.insert(n) || under_tool(n)) continue;
      std::int32_t units = accessor_.getValue(n);
      if (units < normal_units_ && !carved_accessor_.isValueOn(n)) {
        const std::int64_t deposit = std::min<std::int64_t>(normal_units_ - units, flow_units_);
        units += static_cast<std::int32_t>(deposit);
        flow_units_ -= deposit;
        set(n, units);
      }
      if (units > 0) flow_queue_.push_back(n);
      if (flow_units_ == 0) break;
    }
  }
  work_.flow_visits += steps;
  if (flow_units_ == 0 || flow_head_ == flow_queue_.size()) end_flow();
  return steps;
}

void MassGrid::end_flow() {
  if (flow_units_ > 0) {
    // Sealed in by the tool (no reachable room): the rest goes back where it came from
    // and waits for the tool to move.
    const openvdb::Coord back = flow_first_source_;
    const std::int64_t units = std::int64_t{accessor_.getValue(back)} + flow_units_;
    HAPVOX_CHECK_LE(units, std::int64_t{INT32_MAX});
    set(back, static_cast<std::int32_t>(units));
    walled_in_.push_back(back);
    // A source the tool has covered since: the sweep holds material (apply_deletion).
    if (under_tool(back)) sweep_empty_ = false;
    flow_units_ = 0;
  }
  flow_active_ = false;
  flow_queue_.clear();
  flow_head_ = 0;
  flow_visited_.clear();
  ++work_.flows;
}

bool MassGrid::settled() {
  if (flow_active_ || pool_units_ > 0) return false;
  for (const openvdb::Coord& ijk : walled_in_) {
    if (accessor_.getValue(ijk) > threshold_units_) return false;
  }
  while (!queue_.empty()) {
    const Entry& top = queue_.top();
    const std::int32_t current = accessor_.getValue(top.ijk);
    if (current == top.units && current > threshold_units_) return false;
    queue_.pop();
  }
  return true;
}

double MassGrid::max_density() const {
  std::int32_t best = 0;
  for (auto it = grid_->cbeginValueOn(); it; ++it) best = std::max(best, *it);
  return static_cast<double>(best) / kNormalDensityUnits;
}

std::size_t MassGrid::publish_changes(DensityField& mirror) {
  auto out = mirror.mutable_grid().getAccessor();
  for (const openvdb::Coord& ijk : changed_) {
    const std::int32_t units = accessor_.getValue(ijk);
    if (units == 0) {
      out.setValueOff(ijk, 0.0f);
    } else {
      out.setValueOn(ijk, static_cast<float>(units) / kNormalDensityUnits);
    }
  }
  const std::size_t count = changed_.size();
  for (const openvdb::Coord& ijk : changed_) listed_accessor_.setValueOff(ijk);
  changed_.clear();
  return count;
}

DensityField MassGrid::to_density_field() const {
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto out = grid->getAccessor();
  for (auto it = grid_->cbeginValueOn(); it; ++it) {
    const float rho = static_cast<float>(*it) / kNormalDensityUnits;
    if (it.isVoxelValue()) {
      out.setValueOn(it.getCoord(), rho);
    } else {
      openvdb::CoordBBox box;
      it.getBoundingBox(box);
      grid->tree().fill(box, rho, true);
    }
  }
  return DensityField(grid, voxel_size_mm_, origin_mm_, dims_, direction_);
}

}  // namespace hapvox::engine
