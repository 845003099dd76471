#pragma once
// Deletion and progressive relaxation (Prados et al., "Volumetric plastic deformation",
// section 4.3) on an exact integer copy of the density.
//
// Density is stored in fixed point: kNormalDensityUnits units are density 1; the material's
// normal density (RelaxOptions::normal_density, default 1) is what relaxation settles to.
// Every operation moves whole units from voxel to voxel, so the total mass is an exact
// integer invariant: total_mass_units() is equal bit for bit before and after any
// sequence of deletions and relaxation steps.
//
//   1. apply_deletion(c): the tool's sphere at c (swept from c.from_mm for coalesced
//      changes) is emptied in partial volume: a voxel the sphere covers by a fraction f
//      keeps at most (1 - f) of the normal density, and what it loses moves along
//      c.direction to the first voxel the sphere does not cover. Highest priority: the
//      caller applies all queued deletions first.
//   2. relax(budget): take the active voxel of highest density; compute the mean of its
//      3x3x3 neighbourhood; set it back to the normal density; give the excess to the
//      neighbours below the mean, raising them at most to the mean (shares proportional to
//      their room, remainders by a fixed order; material neighbours before empty ones).
//      What they cannot take:
//        - RelaxRule::kFlowToRoom (default): receivers are also capped at the normal
//          density, and the rest joins a pool that flows to the room nearest the
//          over-dense voxels: a breadth-first search from all of them through material
//          (never through the tool) fills every voxel below the normal density it reaches,
//          nearest first, until the pool is empty. Clay is nearly incompressible, so
//          material pushed into the bulk appears at the nearest free surface, as the rim
//          around a pressed tool; the volume settles in one pass.
//          Voxels the tool carved out are not room: clay does not flow back into the
//          groove behind a moving tool (only a later deletion's push can refill them).
//        - RelaxRule::kPaperDiffusion: the rest is spread evenly over the neighbourhood
//          and every voxel left above the normal density (plus the tolerance) is queued:
//          the paper's rule, a diffusion whose settling time grows with the square of the
//          distance to the surface (kept as the benchmark's baseline).
//      Voxels inside the tool never receive material; excess walled in by the tool waits
//      until the next deletion moves the tool.
//
//      Bounded work: relax(n) relaxes at most n active voxels and lets the flow's search
//      expand at most n * RelaxOptions::flow_visits_per_voxel voxels, and pops at most
//      n * kStalePopsPerVoxel stale queue entries (a voxel queued again since: each paid for
//      by the push that made it, but a deletion pushing into the same voxels tick after
//      tick leaves thousands, and one call popping them all ran for tens of ms on the
//      realtime relaxation thread while a deletion waited). A search the budget
//      cuts short resumes where it stopped at the start of the next call; the pool that
//      voxels relaxed meanwhile make waits for the next search. The pool in flight is
//      counted in total_mass_units(), so the total stays exact between calls, and the same
//      sequence of calls gives the same grid (lockstep replays are bit-identical).
//      finish_flows() completes the flows at the end of a run so the grid holds it all.
//
// Not thread-safe: one relaxation thread (or the lockstep loop) owns a MassGrid.

#include <openvdb/openvdb.h>

#include <algorithm>
#include <cstdint>
#include <queue>
#include <vector>

#include "engine/density_field.h"
#include "engine/surface_change.h"
#include "engine/visited_set.h"

namespace hapvox::engine {

/// Fixed-point units per density 1 (the default normal density).
inline constexpr std::int32_t kNormalDensityUnits = 1 << 16;

/// The normal density, a fraction in (0, 1] of density 1, in fixed-point units (at least 1).
std::int32_t normal_density_units(double normal_density);

enum class RelaxRule { kFlowToRoom, kPaperDiffusion };

struct RelaxOptions {
  /// The material's normal (rest) density, the density relaxation settles voxels back to:
  /// a fraction in (0, 1] of density 1 (issue 3: materials have a normal density).
  double normal_density = 1.0;
  /// Settled when no voxel exceeds the normal density by more than this fraction.
  double tolerance = 0.02;
  RelaxRule rule = RelaxRule::kFlowToRoom;
  /// Voxels the flow-to-room search may expand per voxel of relax()'s budget (a visit
  /// reads 6 neighbours, a relaxed voxel 26 and tests each against the tool). At least 1.
  std::size_t flow_visits_per_voxel = 8;
  /// A deletion visits only the voxels holding material (leaf value masks) and leaves out
  /// those the last deletion's sweep covered whole (they are empty: see apply_deletion).
  /// false visits every voxel of the sweep in index order, as before issue 29: the same
  /// grid, bit for bit, at the old cost (the reference the tests and `bench plastic`
  /// compare with).
  bool skip_swept_voxels = true;
};

struct RelaxWork {
  std::uint64_t deleted_voxels = 0;  // voxels deletions took mass from (in part or whole)
  std::uint64_t swept_voxels = 0;    // voxels deletions tested against their sweep
  std::uint64_t relaxed_voxels = 0;  // active voxels processed
  std::uint64_t moved_units = 0;     // mass moved, fixed-point units
  std::uint64_t flow_visits = 0;     // voxels the flow-to-room search visited
  std::uint64_t flows = 0;           // flow-to-room searches run
  std::uint64_t stale_pops = 0;      // queue entries popped that were stale (no work)
};

class MassGrid {
 public:
  /// Fixed-point copy of `field`: q = round(rho * kNormalDensityUnits).
  MassGrid(const DensityField& field, const RelaxOptions& options = {});

  /// Exact total mass in fixed-point units: the grid plus the pool still flowing. O(1): the
  /// grid's sum is kept up to date by every change (set()), in integers.
  std::int64_t total_mass_units() const { return grid_units_ + flowing_units(); }
  /// The same, summed over every active voxel now (a pass over the grid): what the tests
  /// and a run's first and last rows check total_mass_units() against.
  std::int64_t summed_mass_units() const;

  /// Paper step 1. Returns the number of voxels emptied.
  ///
  /// Cost: a tool ploughing in small steps changes only the thin shell its new sweep adds
  /// and the partial-volume rim, so that is what it visits (engine/relax_deletion.cc):
  ///   - Only voxels holding material can lose any. They are the active ones (an emptied
  ///     voxel is turned off), so each leaf's value mask picks them, and a region with no
  ///     leaf is passed over whole.
  ///   - Every voxel whose centre lies within r - |h|/2 of the last deletion's sweep
  ///     (coverage 1 there, as a voxel's width across the surface is at most |h|) was
  ///     emptied by it, and nothing refills the sweep before the next deletion: relaxation
  ///     and the flow never give to a voxel under the tool, and a push lands beyond the
  ///     sweep it comes from. So each column leaves that span out. The one way in (a flow
  ///     sealed in by the tool returning its pool to a source the tool has since covered)
  ///     turns this off for the next deletion.
  /// Sources never receive (a push lands where the sweep does not reach) and pushes add
  /// integers, so the order of visits does not change the grid: the clay is the same, voxel
  /// for voxel, as visiting every voxel of the sweep in order (RelaxOptions::
  /// skip_swept_voxels = false).
  std::size_t apply_deletion(const SurfaceChange& change);

  /// At most this many stale queue entries popped per voxel of relax()'s budget.
  static constexpr std::size_t kStalePopsPerVoxel = 16;

  /// Paper step 2: relaxes at most `max_voxels` active voxels; the flow's search expands at
  /// most max_voxels * flow_visits_per_voxel voxels; at most max_voxels * kStalePopsPerVoxel
  /// stale entries are popped. Returns voxels relaxed plus voxels the search expanded plus
  /// stale entries popped: 0 when there was nothing to do.
  std::size_t relax(std::size_t max_voxels);

  /// Runs the flow in flight, and the one waiting, to the end (no budget): the grid then
  /// holds all the mass. For the end of a run, before the volume is written.
  void finish_flows();

  /// The normal density in fixed-point units.
  std::int32_t normal_units() const { return normal_units_; }
  /// True when no voxel exceeds the normal density plus the tolerance and no pool flows.
  bool settled();
  /// Mass still flowing to room (not yet in the grid), fixed-point units.
  std::int64_t flowing_units() const { return flow_units_ + pool_units_; }
  /// Active voxels waiting (including stale queue entries; an upper bound).
  std::size_t queued() const { return queue_.size(); }
  /// Largest density in the grid, in units of the normal density.
  double max_density() const;

  /// Writes every voxel changed since the last call into `mirror` (as rho = q / units;
  /// 0 becomes inactive background) and forgets them. Returns how many it wrote.
  std::size_t publish_changes(DensityField& mirror);

  /// Moves the list of voxels changed since the last call into `out` (cleared first).
  void take_changes(std::vector<openvdb::Coord>& out) {
    out.clear();
    out.swap(changed_);
    for (const openvdb::Coord& ijk : out) listed_accessor_.setValueOff(ijk);
  }
  bool has_changes() const { return !changed_.empty(); }
  /// Density of one voxel as the float the force model reads.
  float density(const openvdb::Coord& ijk) {
    return static_cast<float>(accessor_.getValue(ijk)) / kNormalDensityUnits;
  }

  /// True when the last deletion's sweep covers any part of the voxel (coverage above 0):
  /// relaxation and the flow never give to it until the next deletion moves the tool.
  /// Asked of every neighbour relaxation gives to and the flow passes, so it is inline and
  /// scalar; its arithmetic is relax_deletion.cc's from_segment and squaredNorm, operation
  /// for operation, so it answers as they did to the last bit.
  bool under_tool(const openvdb::Coord& ijk) const {
    if (!has_tool_) return false;
    const double px = ijk.x() * voxel_size_mm_.x(), py = ijk.y() * voxel_size_mm_.y(),
                 pz = ijk.z() * voxel_size_mm_.z();
    double rx = px - tool_a_mm_.x(), ry = py - tool_a_mm_.y(), rz = pz - tool_a_mm_.z();
    if (tool_len2_mm2_ >= 0.0) {  // a capsule; a sphere's r is p - a
      const double t =
          tool_len2_mm2_ > 0.0
              ? std::clamp((rx * tool_ab_mm_.x() + ry * tool_ab_mm_.y() + rz * tool_ab_mm_.z()) /
                               tool_len2_mm2_,
                           0.0, 1.0)
              : 0.0;
      rx = px - (tool_a_mm_.x() + t * tool_ab_mm_.x());
      ry = py - (tool_a_mm_.y() + t * tool_ab_mm_.y());
      rz = pz - (tool_a_mm_.z() + t * tool_ab_mm_.z());
    }
    const double dist2 = rx * rx + ry * ry + rz * rz;
    // Coverage is above 0 where the distance is below r + w/2, the width w between the
    // smallest voxel side and |h|: surely so within r + min h / 2, never beyond r + |h|/2 (a
    // micron of margin each way).
    if (dist2 <= tool_covers_within_mm2_) return true;
    if (dist2 >= tool_misses_beyond_mm2_) return false;
    return covered_in_band(Vec3d(rx, ry, rz), dist2);
  }

  const RelaxWork& work() const { return work_; }
  const openvdb::Int32Grid& grid() const { return *grid_; }
  /// The density as a float field (for writing .vdb / NRRD), same geometry as the input.
  DensityField to_density_field() const;

 private:
  struct Entry {
    std::int32_t units;
    openvdb::Coord ijk;
    bool operator<(const Entry& other) const {
      // Highest density first; ties in a fixed coordinate order for determinism.
      if (units != other.units) return units < other.units;
      return other.ijk < ijk;
    }
  };

  // One deletion's geometry, grid frame, mm from the grid origin.
  struct Sweep {
    // The loop before issue 29 (RelaxOptions::skip_swept_voxels = false): every voxel in
    // index order, tool_coverage at every test and every step of a push, as the reference.
    bool reference = false;
    Vec3d a_mm, b_mm;  // the sphere's centre swept from a to b
    double radius_mm = 0.0;
    double reach_mm = 0.0;  // radius plus half a voxel diagonal: what it covers in part
    // Squared distances from the segment beyond which coverage is 0 and within which it is 1.
    double zero_beyond_mm2 = 0.0, whole_within_mm2 = -1.0;
    Vec3d push;             // unit direction the removed material moves
    double step_mm = 0.0;   // the push's march step
    openvdb::Coord lo, hi;  // index box of the reach
    // The last sweep's core (every voxel it covered whole, emptied then), left out.
    bool skip_core = false;
    Vec3d core_a_mm, core_b_mm;
    double core_radius_mm = 0.0;
  };

  // Voxels past the volume's box that the flow's visited set still holds densely (clay
  // pushed beyond the edge), and the search queue's room made at construction.
  static constexpr int kFlowMarginVoxels = 8;
  static constexpr std::size_t kFlowQueueReserve = std::size_t{1} << 16;

  void set(const openvdb::Coord& ijk, std::int32_t units);
  void activate_if_over(const openvdb::Coord& ijk, std::int32_t units);
  /// Fraction of a voxel centred at p the swept sphere covers (a linear ramp across the
  /// voxel's width along the distance direction); all in mm from the grid origin.
  double tool_coverage(const Vec3d& p_mm, const Vec3d& a_mm, const Vec3d& b_mm,
                       double radius_mm) const;
  /// tool_coverage for this sweep, without a square root where it is 0 or 1.
  double sweep_coverage(const Sweep& s, const Vec3d& p_mm) const;
  /// The k range of column (i, j) within the sweep's reach (one voxel of slack each way);
  /// false if none.
  bool column_span(const Sweep& s, int i, int j, int& k_lo, int& k_hi) const;
  /// The k range of column (i, j) strictly inside the last sweep's core; false if none or
  /// when the core is not skipped.
  bool core_span(const Sweep& s, int i, int j, int& k_lo, int& k_hi) const;
  /// Visits every voxel of the sweep in index order (the reference).
  std::size_t delete_every_voxel(const Sweep& s);
  /// Visits the active voxels of the leaves the sweep reaches, less the last core.
  std::size_t delete_in_leaves(const Sweep& s);
  /// Empties one voxel in partial volume and pushes what it loses; true if it lost any.
  bool delete_voxel(const Sweep& s, const openvdb::Coord& source);
  /// under_tool between its two bounds: the coverage ramp itself.
  bool covered_in_band(const Vec3d& r_mm, double dist2_mm2) const;
  void relax_voxel(const openvdb::Coord& ijk, std::int32_t units);
  void start_flow();
  std::size_t advance_flow(std::size_t max_steps);
  void end_flow();

  openvdb::Int32Grid::Ptr grid_;
  openvdb::Int32Grid::Accessor accessor_;
  Vec3d voxel_size_mm_;
  Vec3d origin_mm_;
  Vec3i dims_;
  Mat3d direction_;  // world directions of the index axes (DensityField)
  std::int32_t normal_units_;
  std::int32_t threshold_units_;
  RelaxRule rule_;
  std::size_t flow_visits_per_voxel_;
  std::priority_queue<Entry> queue_;
  std::vector<openvdb::Coord> changed_;
  // Voxels already in changed_, so each is listed (and published) once.
  openvdb::MaskGrid::Ptr listed_ = openvdb::MaskGrid::create(false);
  openvdb::MaskGrid::Accessor listed_accessor_ = listed_->getAccessor();
  RelaxWork work_;
  // Flow to room: excess waiting for the next search and the voxels it came from; the
  // search in flight (its pool, first source, queue with its head, visited set), kept
  // between calls so it can resume and a warmed-up grid does not allocate for it.
  std::int64_t grid_units_ = 0;  // the sum over the grid, kept by set()
  std::int64_t pool_units_ = 0;
  std::vector<openvdb::Coord> pool_sources_;
  bool flow_active_ = false;
  std::int64_t flow_units_ = 0;
  openvdb::Coord flow_first_source_;
  std::vector<openvdb::Coord> flow_queue_;
  std::size_t flow_head_ = 0;
  VisitedSet flow_visited_;  // dense over the volume's box, sized at construction
  // Voxels emptied by deletions (and not refilled by one since): never room for the flow.
  openvdb::MaskGrid::Ptr carved_ = openvdb::MaskGrid::create(false);
  openvdb::MaskGrid::Accessor carved_accessor_ = carved_->getAccessor();
  // Over-dense voxels walled in by the tool, queued again after the next deletion.
  std::vector<openvdb::Coord> walled_in_;
  // The tool's last swept sphere (mm, from index space), which relaxation must not fill.
  bool has_tool_ = false;
  // Every voxel the last sweep covered whole is still empty (apply_deletion's skip), and
  // that sweep exactly as its coverage was computed.
  bool sweep_empty_ = false;
  bool skip_swept_voxels_ = true;
  Vec3d last_from_mm_ = Vec3d::Zero();
  Vec3d last_to_mm_ = Vec3d::Zero();
  Vec3d tool_a_mm_ = Vec3d::Zero();
  Vec3d tool_b_mm_ = Vec3d::Zero();
  Vec3d tool_ab_mm_ = Vec3d::Zero();  // b - a
  double tool_len2_mm2_ = -1.0;       // |b - a|^2; -1 for a sphere (a == b)
  double tool_radius_mm_ = 0.0;
  double tool_covers_within_mm2_ = -1.0, tool_misses_beyond_mm2_ = 0.0;  // under_tool's bounds
};

}  // namespace hapvox::engine
