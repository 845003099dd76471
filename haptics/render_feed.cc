#include "haptics/render_feed.h"

namespace hapvox::haptics {

// Every access is sequentially consistent: one total order makes the seqlock's argument
// trivial, and ThreadSanitizer (which does not model standalone fences) sees it whole. On
// x86 that is nine locked stores a tick, well under a microsecond.
void ToolStateMailbox::publish(const RenderToolState& state) noexcept {
  const std::uint64_t s = sequence_.load();
  sequence_.store(s + 1);
  for (int a = 0; a < 3; ++a) {
    values_[a].store(state.center_mm[a]);
    values_[3 + a].store(state.displacement_mm[a]);
  }
  in_contact_.store(state.in_contact);
  tick_.store(state.tick);
  sequence_.store(s + 2);
}

RenderToolState ToolStateMailbox::read() const noexcept {
  RenderToolState state;
  while (true) {
    const std::uint64_t before = sequence_.load();
    if (before & 1u) continue;  // the writer is mid-update: it is a few stores from done
    for (int a = 0; a < 3; ++a) {
      state.center_mm[a] = values_[a].load();
      state.displacement_mm[a] = values_[3 + a].load();
    }
    state.in_contact = in_contact_.load();
    state.tick = tick_.load();
    if (sequence_.load() == before) return state;
  }
}

void VoxelPatchQueue::offer_patch(const VoxelPatch& patch) {
  if (patch_backlog_head_ == patch_backlog_.size() && queue_.try_push(patch)) return;
  if (patch_backlog_head_ == patch_backlog_.size()) {
    full_events_.fetch_add(1, std::memory_order_relaxed);
  }
  patch_backlog_.push_back(patch);
}

bool VoxelPatchQueue::retry_patches() {
  while (patch_backlog_head_ < patch_backlog_.size() &&
         queue_.try_push(patch_backlog_[patch_backlog_head_])) {
    ++patch_backlog_head_;
  }
  if (patch_backlog_head_ < patch_backlog_.size()) return false;
  patch_backlog_.clear();
  patch_backlog_head_ = 0;
  return true;
}

void VoxelPatchQueue::offer(const std::vector<openvdb::Coord>& coords, engine::MassGrid& mass) {
  pending_.clear();
  pending_.swap(backlog_);
  pending_.insert(pending_.end(), coords.begin(), coords.end());
  std::size_t i = 0;
  for (; i < pending_.size(); ++i) {
    // The density now, not when the change was made: a voxel waiting in the backlog goes
    // out with its latest value.
    if (!queue_.try_push(VoxelPatch{pending_[i], mass.density(pending_[i])})) break;
  }
  if (i < pending_.size()) {
    full_events_.fetch_add(1, std::memory_order_relaxed);
    backlog_.assign(pending_.begin() + static_cast<std::ptrdiff_t>(i), pending_.end());
  }
}

}  // namespace hapvox::haptics
