#include "engine/labels/label_map.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/labels/text.h"

namespace hapvox::engine::labels {

using detail::number;
using detail::size_text;
using detail::triple;

namespace {

const std::array<Vec3i, 6> kNeighbours = {Vec3i(1, 0, 0),  Vec3i(-1, 0, 0), Vec3i(0, 1, 0),
                                          Vec3i(0, -1, 0), Vec3i(0, 0, 1),  Vec3i(0, 0, -1)};

Vec3i unravel(std::int64_t i, const Vec3i& dims) {
  const std::int64_t nx = dims.x(), ny = dims.y();
  return Vec3i(static_cast<int>(i % nx), static_cast<int>((i / nx) % ny),
               static_cast<int>(i / (nx * ny)));
}

std::int64_t sample_count(const Vec3i& dims) {
  return static_cast<std::int64_t>(dims.x()) * dims.y() * dims.z();
}

}  // namespace

// ---------------------------------------------------------------------------------------
// LabelMap.

LabelMap::LabelMap(const Vec3i& dims, const Vec3d& spacing_mm, const Vec3d& origin_mm)
    : dims_(dims), spacing_mm_(spacing_mm), origin_mm_(origin_mm) {
  HAPVOX_CHECK(dims.minCoeff() > 0);
  HAPVOX_CHECK(spacing_mm.minCoeff() > 0.0);
  labels_.assign(static_cast<std::size_t>(sample_count(dims)), 0);
}

LabelMap LabelMap::like(const RawVolume& volume) {
  return LabelMap(volume.dims, volume.spacing_mm, volume.origin_mm);
}

LabelMap LabelMap::like(const DensityField& field) {
  return LabelMap(field.dims(), field.voxel_size_mm(), field.origin_mm());
}

std::optional<Vec3i> LabelMap::voxel_at_world(const Vec3d& p_mm) const {
  const Vec3d index = world_to_index(p_mm);
  if (!index.allFinite()) return std::nullopt;
  // Cells are [i - 0.5, i + 0.5); compare before converting so huge values cannot overflow.
  if ((index.array() < -0.5).any() || (index.array() >= dims_.cast<double>().array() - 0.5).any()) {
    return std::nullopt;
  }
  const Vec3i ijk = (index.array() + 0.5).floor().cast<int>();
  return contains(ijk) ? std::optional<Vec3i>(ijk) : std::nullopt;
}

Label LabelMap::at(const Vec3i& ijk) const {
  HAPVOX_CHECK(contains(ijk));
  return labels_[static_cast<std::size_t>(linear_index(ijk))];
}

void LabelMap::set(const Vec3i& ijk, Label label) {
  HAPVOX_CHECK(contains(ijk));
  labels_[static_cast<std::size_t>(linear_index(ijk))] = label;
}

Label LabelMap::at_world(const Vec3d& p_mm) const {
  const auto ijk = voxel_at_world(p_mm);
  return ijk ? at(*ijk) : 0;
}

std::map<Label, std::int64_t> LabelMap::voxel_counts() const {
  std::map<Label, std::int64_t> counts;
  for (const Label l : labels_) ++counts[l];
  return counts;
}

bool LabelMap::is_boundary(const Vec3i& ijk) const {
  const Label own = at(ijk);
  for (const Vec3i& step : kNeighbours) {
    const Vec3i n = ijk + step;
    if (contains(n) && labels_[static_cast<std::size_t>(linear_index(n))] != own) return true;
  }
  return false;
}

std::vector<Vec3i> LabelMap::boundary_voxels(Label label) const {
  std::vector<Vec3i> out;
  for (std::int64_t i = 0; i < voxel_count(); ++i) {
    if (labels_[static_cast<std::size_t>(i)] != label) continue;
    const Vec3i ijk = unravel(i, dims_);
    if (is_boundary(ijk)) out.push_back(ijk);
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Volumes.

LabelMap label_volume_to_map(const RawVolume& label_volume, const std::string& label_source,
                             const RawVolume& intensity, const std::string& intensity_name) {
  if (label_volume.dims != intensity.dims) {
    throw InputError(label_source, "label volume is " + size_text(label_volume.dims) +
                                       " voxels but the intensity volume " + intensity_name +
                                       " is " + size_text(intensity.dims));
  }
  const auto same = [&](const char* what, const Vec3d& label_value, const Vec3d& value,
                        double tolerance) {
    if (((label_value - value).array().abs() <= tolerance).all()) return;
    throw InputError(label_source, std::string("label volume ") + what + " " + triple(label_value) +
                                       " mm differs from the intensity volume " + intensity_name +
                                       "'s " + triple(value) + " mm");
  };
  same("spacing", label_volume.spacing_mm, intensity.spacing_mm,
       1e-5 * intensity.spacing_mm.maxCoeff());
  same("origin", label_volume.origin_mm, intensity.origin_mm,
       1e-3 * intensity.spacing_mm.minCoeff());
  LabelMap map = LabelMap::like(intensity);
  std::vector<Label>& labels = map.mutable_data();
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const float v = label_volume.intensity[i];
    std::string problem;
    if (!std::isfinite(v)) {
      problem = "non-finite value ";
    } else if (v < 0.0f) {
      problem = "negative value ";
    } else if (v != std::floor(v)) {
      problem = "non-integer value ";
    } else if (v > static_cast<float>(kMaxLabel)) {
      problem = "label above " + number(kMaxLabel) + ", ";
    }
    if (!problem.empty()) {
      throw InputError(label_source,
                       "label volume holds " + problem + number(v) + " at voxel " +
                           triple(unravel(static_cast<std::int64_t>(i), label_volume.dims)));
    }
    labels[i] = static_cast<Label>(v);
  }
  return map;
}

LabelMap read_label_volume(const std::string& label_spec, const RawVolume& intensity,
                           const std::string& intensity_name) {
  return label_volume_to_map(read_scalar_volume(label_spec), label_spec, intensity, intensity_name);
}

DensityField label_field(const LabelMap& map) {
  initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  auto accessor = grid->getAccessor();
  const std::vector<Label>& labels = map.data();
  for (std::int64_t i = 0; i < map.voxel_count(); ++i) {
    const Label l = labels[static_cast<std::size_t>(i)];
    if (l == 0) continue;
    const Vec3i ijk = unravel(i, map.dims());
    accessor.setValue(openvdb::Coord(ijk.x(), ijk.y(), ijk.z()), static_cast<float>(l));
  }
  return DensityField(grid, map.spacing_mm(), map.origin_mm(), map.dims());
}

RawVolume label_samples(const LabelMap& map) {
  RawVolume raw;
  raw.dims = map.dims();
  raw.spacing_mm = map.spacing_mm();
  raw.origin_mm = map.origin_mm();
  raw.sample_type = "int32";
  raw.intensity.resize(map.data().size());
  std::transform(map.data().begin(), map.data().end(), raw.intensity.begin(),
                 [](Label l) { return static_cast<float>(l); });
  if (!raw.intensity.empty()) {
    const auto [lo, hi] = std::minmax_element(raw.intensity.begin(), raw.intensity.end());
    raw.min_intensity = *lo;
    raw.max_intensity = *hi;
  }
  return raw;
}

// ---------------------------------------------------------------------------------------
// Intensity ranges and region growing.

LabelMap labels_from_intensity_ranges(const RawVolume& intensity,
                                      const std::vector<IntensityRange>& ranges) {
  for (const IntensityRange& r : ranges) {
    HAPVOX_CHECK_GE(r.label, 0);
    HAPVOX_CHECK_LE(r.low, r.high);
  }
  LabelMap map = LabelMap::like(intensity);
  std::vector<Label>& labels = map.mutable_data();
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const double v = intensity.intensity[i];
    for (const IntensityRange& r : ranges) {
      if (v >= r.low && v <= r.high) {
        labels[i] = r.label;
        break;
      }
    }
  }
  return map;
}

std::int64_t grow_region(LabelMap& map, const RawVolume& intensity, const Seed& seed,
                         double tolerance, const std::string& source) {
  HAPVOX_CHECK(map.dims() == intensity.dims);
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance)) {
    throw InputError(
        source, "region-growing tolerance must be a finite number >= 0, got " + number(tolerance));
  }
  if (seed.label <= 0 || seed.label > kMaxLabel) {
    throw InputError(
        source, "seed label must lie in [1, " + number(kMaxLabel) + "], got " + number(seed.label));
  }
  const auto start = map.voxel_at_world(seed.point_mm);
  if (!start) {
    const Vec3d lo = map.index_to_world(Vec3d::Constant(-0.5));
    const Vec3d hi = map.index_to_world(map.dims().cast<double>() - Vec3d::Constant(0.5));
    throw InputError(source, "seed " + triple(seed.point_mm) + " mm lies outside the volume " +
                                 triple(lo) + " to " + triple(hi) + " mm");
  }
  std::vector<Label>& labels = map.mutable_data();
  const auto index = [&](const Vec3i& ijk) {
    return static_cast<std::size_t>(map.linear_index(ijk));
  };
  if (labels[index(*start)] != 0) return 0;
  const double reference = intensity.intensity[index(*start)];
  const auto inside = [&](std::size_t i) {
    return labels[i] == 0 && std::abs(intensity.intensity[i] - reference) <= tolerance;
  };
  std::vector<Vec3i> stack = {*start};
  labels[index(*start)] = seed.label;
  std::int64_t grown = 1;
  while (!stack.empty()) {
    const Vec3i v = stack.back();
    stack.pop_back();
    for (const Vec3i& step : kNeighbours) {
      const Vec3i n = v + step;
      if (!map.contains(n) || !inside(index(n))) continue;
      labels[index(n)] = seed.label;
      ++grown;
      stack.push_back(n);
    }
  }
  return grown;
}

LabelMap grow_regions(const RawVolume& intensity, const std::vector<Seed>& seeds, double tolerance,
                      const std::string& source) {
  LabelMap map = LabelMap::like(intensity);
  for (const Seed& seed : seeds) grow_region(map, intensity, seed, tolerance, source);
  return map;
}

// ---------------------------------------------------------------------------------------
// Picking.

std::optional<Pick> pick_voxel(const RawVolume& intensity, const Vec3d& origin_mm,
                               const Vec3d& direction, const std::function<float(float)>& opacity,
                               double threshold) {
  HAPVOX_CHECK(direction.allFinite() && direction.norm() > 0.0);
  HAPVOX_CHECK(threshold > 0.0 && threshold <= 1.0);
  HAPVOX_CHECK_EQ(static_cast<std::int64_t>(intensity.intensity.size()),
                  sample_count(intensity.dims));
  const Vec3d& spacing = intensity.spacing_mm;
  // Index space, with t in millimetres along the unit direction: p(t) = o + t d.
  const Vec3d o = (origin_mm - intensity.origin_mm).cwiseQuotient(spacing);
  const Vec3d d = direction.normalized().cwiseQuotient(spacing);
  const Vec3d lo = Vec3d::Constant(-0.5);
  const Vec3d hi = intensity.dims.cast<double>() - Vec3d::Constant(0.5);

  // Slabs: the part of the ray inside the volume's box.
  double t_in = 0.0;
  double t_out = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < lo[a] || o[a] >= hi[a]) return std::nullopt;
      continue;
    }
    const double t0 = (lo[a] - o[a]) / d[a];
    const double t1 = (hi[a] - o[a]) / d[a];
    t_in = std::max(t_in, std::min(t0, t1));
    t_out = std::min(t_out, std::max(t0, t1));
  }
  if (!(t_in < t_out)) return std::nullopt;

  // Amanatides–Woo: the voxel the ray enters, then one face crossing at a time.
  const Vec3d entry = o + t_in * d;
  Vec3i voxel;
  Vec3i step;
  Vec3d t_next;
  Vec3d t_delta;
  for (int a = 0; a < 3; ++a) {
    voxel[a] = std::clamp(static_cast<int>(std::floor(entry[a] + 0.5)), 0, intensity.dims[a] - 1);
    step[a] = d[a] > 0.0 ? 1 : (d[a] < 0.0 ? -1 : 0);
    if (step[a] == 0) {
      t_next[a] = t_delta[a] = std::numeric_limits<double>::infinity();
      continue;
    }
    const double face = voxel[a] + 0.5 * step[a];
    t_next[a] = (face - o[a]) / d[a];
    t_delta[a] = 1.0 / std::abs(d[a]);
  }

  const double reference_mm = spacing.minCoeff();  // "one voxel of path"
  double t = t_in;
  double accumulated = 0.0;
  while (t < t_out) {
    int axis = 0;
    if (t_next[1] < t_next[axis]) axis = 1;
    if (t_next[2] < t_next[axis]) axis = 2;
    const double t_exit = std::min(t_next[axis], t_out);
    const double length = t_exit - t;
    if (length > 0.0) {
      const std::size_t i =
          static_cast<std::size_t>(voxel.x()) +
          static_cast<std::size_t>(intensity.dims.x()) *
              (static_cast<std::size_t>(voxel.y()) +
               static_cast<std::size_t>(intensity.dims.y()) * static_cast<std::size_t>(voxel.z()));
      float a = opacity(intensity.intensity[i]);
      if (!(a > 0.0f)) a = 0.0f;  // also NaN
      if (a > 1.0f) a = 1.0f;
      const double a_segment = 1.0 - std::pow(1.0 - a, length / reference_mm);
      accumulated += (1.0 - accumulated) * a_segment;
      if (accumulated >= threshold) return Pick{voxel, t, accumulated};
    }
    t = t_exit;
    voxel[axis] += step[axis];
    t_next[axis] += t_delta[axis];
    if (voxel[axis] < 0 || voxel[axis] >= intensity.dims[axis]) break;
  }
  return std::nullopt;
}

}  // namespace hapvox::engine::labels
