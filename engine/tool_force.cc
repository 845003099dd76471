#include "engine/tool_force.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine {
namespace {

constexpr double kPi = 3.14159265358979323846;

// OpenVDB leaf: 8^3 voxels, linear offset (x << 6) | (y << 3) | z.
constexpr int kLeafDim = 8;
constexpr int kLeafMask = kLeafDim - 1;

int fibonacci_sample_count(double radius_mm, double spacing_mm, int min_count, int max_count) {
  const double area = 4.0 * kPi * radius_mm * radius_mm;
  const double wanted = std::ceil(area / (spacing_mm * spacing_mm));
  return static_cast<int>(std::clamp(wanted, double(min_count), double(max_count)));
}

}  // namespace

const char* contact_law_name(ContactLaw law) {
  switch (law) {
    case ContactLaw::kHertz:
      return "hertz";
    case ContactLaw::kPaper:
      return "paper";
  }
  return "?";
}

double ContactIntegral::contact_radius_mm() const {
  return std::sqrt(std::max(0.0, ramp_factor * contact_area_mm2) / (2.0 * kPi));
}

ToolForceState::ToolForceState(const DensityField& field)
    : accessors{field.grid().getConstAccessor(), field.grid().getConstAccessor()} {}

ToolForceState::ToolForceState(const DensityField& buffer0, const DensityField& buffer1)
    : accessors{buffer0.grid().getConstAccessor(), buffer1.grid().getConstAccessor()} {}

ToolForceModel::ToolForceModel(const DensityField& field, const ToolForceOptions& options,
                               const TissueMap* tissue)
    : field_(&field), tissue_(tissue), options_(options) {
  lame_ = lame_parameters(options.material);
  const double d = options.tool.diameter_mm;
  if (!std::isfinite(d) || d <= 0.0) {
    std::ostringstream out;
    out << "tool diameter must be positive and finite, got " << d << " mm";
    throw InputError("tool", out.str());
  }
  if (!std::isfinite(options.reference_length_mm) || options.reference_length_mm < 0.0) {
    throw InputError("material", "reference length must be positive (or 0 for the tool radius)");
  }
  if (options.contact_law == ContactLaw::kHertz && options.reference_length_mm != 0.0) {
    throw InputError("material",
                     "a reference length needs the paper's contact law (the Hertz law measures "
                     "it from the contact)");
  }
  if (!(options.surface_density > 0.0 && options.surface_density <= 1.0)) {
    std::ostringstream out;
    out << "surface density must lie in (0, 1], got " << options.surface_density;
    throw InputError("material", out.str());
  }
  if (!(options.sample_spacing_voxels > 0.0) || options.min_surface_samples < 1 ||
      options.max_surface_samples < options.min_surface_samples) {
    throw InputError("tool", "surface sampling options are out of range");
  }
  const PlasticMaterial& plastic = options.plastic;
  if (plastic.enabled) {
    if (!std::isfinite(plastic.yield_stress_pa) || plastic.yield_stress_pa <= 0.0) {
      std::ostringstream out;
      out << "yield stress must be positive and finite, got " << plastic.yield_stress_pa << " Pa";
      throw InputError("material", out.str());
    }
    // Below every material's E: the hardening modulus E E_ep / (E - E_ep) must be finite.
    const double e =
        tissue != nullptr ? tissue->min_youngs_modulus_pa() : options.material.youngs_modulus_pa;
    if (!std::isfinite(plastic.elastoplastic_modulus_pa) ||
        plastic.elastoplastic_modulus_pa < 0.0 || plastic.elastoplastic_modulus_pa >= e) {
      std::ostringstream out;
      out << "elasto-plastic modulus must lie in [0, E), got " << plastic.elastoplastic_modulus_pa
          << " Pa";
      if (tissue != nullptr) out << " (the softest material's E is " << e << " Pa)";
      throw InputError("material", out.str());
    }
  }
  const double radius_mm = 0.5 * d;
  fixed_reference_length_mm_ =
      options.contact_law == ContactLaw::kPaper
          ? (options.reference_length_mm > 0.0 ? options.reference_length_mm : radius_mm)
          : 0.0;
  surface_density_ = static_cast<float>(options.surface_density);
  const Vec3d voxel = field.voxel_size_mm();
  const Mat3d to_grid = field.direction().transpose();  // world -> grid frame
  // A sphere reaches radius / voxel along every index axis, however the grid is turned.
  tool_radius_index_ = Vec3d::Constant(radius_mm).cwiseQuotient(voxel);

  // Fibonacci lattice: near-uniform points of equal area, so every sample weighs
  // 4 pi R^2 / M and the integral needs no per-point weights.
  const int count =
      fibonacci_sample_count(radius_mm, options.sample_spacing_voxels * voxel.minCoeff(),
                             options.min_surface_samples, options.max_surface_samples);
  sample_area_mm2_ = 4.0 * kPi * radius_mm * radius_mm / count;
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Vec3d> normals(count);
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    normals[i] = Vec3d(r * std::cos(phi), r * std::sin(phi), z);
  }
  // Order points by the 4-voxel cell they fall in so consecutive reads hit the same leaf.
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  auto cell = [&](int i) {
    const Vec3d q = (to_grid * normals[i] * radius_mm).cwiseQuotient(voxel) / 4.0;
    return std::array<int, 3>{int(std::floor(q.z())), int(std::floor(q.y())),
                              int(std::floor(q.x()))};
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cell(a) < cell(b); });
  sample_offsets_index_.reserve(count);
  sample_normals_.reserve(count);
  for (int i : order) {
    // Offsets in index space, normals in world: the force comes out in world.
    sample_offsets_index_.push_back(
        (to_grid * normals[i] * radius_mm).cwiseQuotient(voxel).cast<float>());
    sample_normals_.push_back(normals[i].cast<float>());
  }

  active_bbox_ = field.grid().evalActiveVoxelBoundingBox();
  active_bbox_.expand(1);
  // Sculpted material can flow anywhere: no early-out on the initial bounds.
  if (options.plastic.enabled) active_bbox_ = openvdb::CoordBBox::inf();
}

ToolForceState ToolForceModel::make_state() const {
  ToolForceState state(*field_);
  reserve_caches(state);
  if (tissue_ != nullptr) state.tissue_accessor.emplace(tissue_->slots().getConstAccessor());
  return state;
}

ToolForceState ToolForceModel::make_state(const DensityField& second) const {
  ToolForceState state(*field_, second);
  reserve_caches(state);
  if (tissue_ != nullptr) state.tissue_accessor.emplace(tissue_->slots().getConstAccessor());
  return state;
}

void ToolForceModel::reserve_caches(ToolForceState& state) const {
  state.window.reserve(tool_radius_index_);
  state.stencils.reserve(sample_offsets_index_);
  state.sample_densities.assign(sample_offsets_index_.size(), 0.0f);
}

bool ToolForceModel::may_touch(const Vec3d& c) const {
  // Far outside any grid (a trace in the wrong units): index arithmetic would overflow.
  constexpr double kMaxIndex = 1 << 30;
  if (!c.allFinite() || c.cwiseAbs().maxCoeff() > kMaxIndex) return false;
  if (active_bbox_.empty()) return false;
  const openvdb::Coord lo = active_bbox_.min();
  const openvdb::Coord hi = active_bbox_.max();
  for (int a = 0; a < 3; ++a) {
    if (c[a] + tool_radius_index_[a] < lo[a] || c[a] - tool_radius_index_[a] > hi[a]) return false;
  }
  return true;
}

float ToolForceModel::sample_density(const Eigen::Vector3f& q, ToolForceState& s) const {
  if (s.window.contains(q)) return s.window.sample(q);
  // Outside the window (the pole's line reaches past the tool, or no window): the tree,
  // the last leaf found kept.
  const StencilPoint p = locate_stencil(q);
  const int lx = p.ix & kLeafMask;
  const int ly = p.iy & kLeafMask;
  const int lz = p.iz & kLeafMask;
  float v[8];
  if (lx < kLeafMask && ly < kLeafMask && lz < kLeafMask) {
    // The 2x2x2 stencil lies in one leaf (7 times in 10): read its buffer directly.
    const openvdb::Coord origin(p.ix & ~kLeafMask, p.iy & ~kLeafMask, p.iz & ~kLeafMask);
    if (origin != s.cached_leaf_origin) {
      s.cached_leaf_origin = origin;
      s.cached_leaf = s.accessor().probeConstLeaf(origin);
      if (s.cached_leaf == nullptr) s.cached_tile_value = s.accessor().getValue(origin);
    }
    if (s.cached_leaf == nullptr) return s.cached_tile_value;  // a tile: constant inside
    const float* leaf = s.cached_leaf->buffer().data() + ((lx << 6) | (ly << 3) | lz);
    const int offsets[8] = {0, 1, 8, 9, 64, 65, 72, 73};
    for (int k = 0; k < 8; ++k) v[k] = leaf[offsets[k]];
  } else {
    auto& a = s.accessor();
    for (int k = 0; k < 8; ++k) {
      v[k] = a.getValue(openvdb::Coord(p.ix + (k >> 2), p.iy + ((k >> 1) & 1), p.iz + (k & 1)));
    }
  }
  return trilinear(v, p.fx, p.fy, p.fz);
}

ContactIntegral ToolForceModel::integrate_contact(const Vec3d& center_mm, ToolForceState& s) const {
  ContactIntegral result;
  const Vec3d center_index = field_->world_to_index(center_mm);
  if (!may_touch(center_index)) return result;
  const Eigen::Vector3f c = center_index.cast<float>();
  const bool windowed = s.use_read_caches && s.window.cover(center_index, s.accessor());
  const std::size_t n = sample_offsets_index_.size();
  const float* densities = nullptr;
  if (windowed) {
    densities = s.stencils.sample(c, s.window);
  } else {
    for (std::size_t k = 0; k < n; ++k)
      s.sample_densities[k] = sample_density(c + sample_offsets_index_[k], s);
    densities = s.sample_densities.data();
  }
  // Each term in float, the sums in double: bounded rounding, few conversions. Scalar
  // sums, so that they stay in registers.
  double sum_x = 0.0, sum_y = 0.0, sum_z = 0.0, sum_density = 0.0;
  int in_contact = 0;
  float max_density = 0.0f;
  for (std::size_t k = 0; k < n; ++k) {
    const float rho = densities[k];
    if (rho > 0.0f) {
      const Eigen::Vector3f& normal = sample_normals_[k];
      sum_x += double(rho * normal.x());
      sum_y += double(rho * normal.y());
      sum_z += double(rho * normal.z());
      sum_density += rho;
      max_density = std::max(max_density, rho);
      ++in_contact;
      if (tissue_ != nullptr) add_tissue_sample(c + sample_offsets_index_[k], normal, s, result);
    }
  }
  const Vec3d sum_normal(sum_x, sum_y, sum_z);
  result.area_vector_mm2 = sum_normal * sample_area_mm2_;
  result.contact_area_mm2 = sum_density * sample_area_mm2_;
  if (tissue_ != nullptr) {
    result.lambda_area_vector_pa_mm2 *= sample_area_mm2_;
    result.mu_area_vector_pa_mm2 *= sample_area_mm2_;
    result.modulus_area_pa_mm2 *= sample_area_mm2_;
    result.poisson_area_mm2 *= sample_area_mm2_;
    result.yield_area_pa_mm2 *= sample_area_mm2_;
  }
  result.samples_in_contact = in_contact;
  result.max_density = max_density;
  return result;
}

void ToolForceModel::add_tissue_sample(const Eigen::Vector3f& q, const Eigen::Vector3f& normal,
                                       ToolForceState& s, ContactIntegral& result) const {
  // The point's material: its trilinear stencil's corners, each weighted by its trilinear
  // weight times its density, so the weights sum to the point's density and an empty
  // voxel (whatever its slot) lends nothing. Only contact points come here.
  const float fx0 = std::floor(q.x());
  const float fy0 = std::floor(q.y());
  const float fz0 = std::floor(q.z());
  const float f[3] = {q.x() - fx0, q.y() - fy0, q.z() - fz0};
  const openvdb::Coord base(static_cast<int>(fx0), static_cast<int>(fy0), static_cast<int>(fz0));
  const std::vector<TissueMap::Row>& rows = tissue_->rows();
  double lambda = 0.0, mu = 0.0, modulus = 0.0, poisson = 0.0, yield = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = (corner >> 2) & 1, dy = (corner >> 1) & 1, dz = corner & 1;
    const openvdb::Coord ijk = base.offsetBy(dx, dy, dz);
    const float rho = s.accessor().getValue(ijk);
    if (!(rho > 0.0f)) continue;
    const double w = double(dx ? f[0] : 1.0f - f[0]) * double(dy ? f[1] : 1.0f - f[1]) *
                     double(dz ? f[2] : 1.0f - f[2]) * double(rho);
    const TissueMap::Row& row = rows[static_cast<std::size_t>(s.tissue_accessor->getValue(ijk))];
    lambda += w * row.lambda_pa;
    mu += w * row.mu_pa;
    modulus += w * row.youngs_modulus_pa;
    poisson += w * row.poisson_ratio;
    yield += w * row.yield_stress_pa;
  }
  const Vec3d n = normal.cast<double>();
  result.lambda_area_vector_pa_mm2 += lambda * n;
  result.mu_area_vector_pa_mm2 += mu * n;
  result.modulus_area_pa_mm2 += modulus;
  result.poisson_area_mm2 += poisson;
  result.yield_area_pa_mm2 += yield;
}

bool ToolForceModel::touches(const Vec3d& center_mm, ToolForceState& s) const {
  const Vec3d center_index = field_->world_to_index(center_mm);
  if (!may_touch(center_index)) return false;
  const Eigen::Vector3f c = center_index.cast<float>();
  const bool windowed = s.use_read_caches && s.window.cover(center_index, s.accessor());
  for (const auto& offset : sample_offsets_index_) {
    const Eigen::Vector3f q = c + offset;
    if ((windowed ? s.window.sample(q) : sample_density(q, s)) >= surface_density_) return true;
  }
  return false;
}

Vec3d ToolForceModel::refine_contact_origin(const Vec3d& free_mm, const Vec3d& touching_mm,
                                            ToolForceState& s) const {
  Vec3d lo = free_mm;
  Vec3d hi = touching_mm;
  for (int i = 0; i < options_.onset_refinement_steps; ++i) {
    const Vec3d mid = 0.5 * (lo + hi);
    if (touches(mid, s)) {
      hi = mid;
    } else {
      lo = mid;
    }
  }
  if (options_.contact_law != ContactLaw::kHertz) return lo;  // the paper's x0, as it was
  // The first sample to reach the surface is rarely the pole: put x0 where the pole meets
  // the surface, along the contact normal.
  const PoleDepth pole = pole_depth(lo, s.normal, s);
  return pole.surface_found ? Vec3d(lo - pole.depth_mm * s.normal) : lo;
}

void ToolForceModel::step(const Vec3d& x_mm, ToolForceState& s) const {
  ++s.steps;
  s.surface_change_emitted = false;
  s.contact = integrate_contact(x_mm, s);
  // Contact starts at the material's nominal surface, not at the first trace of density
  // (half a voxel early): the indentation is then independent of the voxel size.
  const bool contact = s.contact.max_density >= surface_density_;
  if (!contact) {
    s.in_contact = false;
    s.contact_origin_mm = x_mm;
    s.displacement_mm.setZero();
    s.indentation_mm = 0.0;
    s.normal.setZero();
    s.normal_force_n = 0.0;
    s.friction_force_n.setZero();
    s.slipping = false;
    s.reference_length_mm = 0.0;
    s.stress_pa.setZero();
    s.force_n.setZero();
    s.zone = PlasticZone::kNoContact;
    s.strain = 0.0;
    s.stress_measure_pa = 0.0;
  } else {
    const bool onset = !s.in_contact;
    if (onset) {
      // A new contact: elastic again, with the material's own yield stress, and no
      // normal until its contact integral gives one.
      s.normal.setZero();
      s.plastic_strain = 0.0;
      s.plastic_flow_mm = 0.0;
      s.stress_measure_pa = 0.0;
      s.yield_stress_pa = contact_yield_stress_pa(s.contact);
      s.zone = PlasticZone::kElastic;
      ++s.contact_onsets;
    }
    update_contact_normal(s);
    if (onset) {
      if (s.has_position) {
        s.contact_origin_mm = refine_contact_origin(s.last_position_mm, x_mm, s);
      } else {
        s.contact_origin_mm = x_mm;  // no free position seen yet: start unstrained
        s.last_position_mm = x_mm;
        ++s.started_in_contact;
      }
    }
    s.in_contact = true;
    apply_contact_law(x_mm, s);
  }
  s.last_position_mm = x_mm;
  s.has_position = true;
}

ContactIntegral ToolForceModel::integrate_contact_naive(const Vec3d& center_mm,
                                                        ToolForceState& s) const {
  ContactIntegral result;
  const Vec3d voxel = field_->voxel_size_mm();
  const Vec3d c = field_->world_to_index(center_mm);
  const double radius_mm = tool_radius_mm();
  const double shell_mm = voxel.minCoeff();
  // A shell one voxel thick has volume ~ area x thickness, so each voxel stands for
  // voxel_volume / thickness of surface.
  const double area_per_voxel = voxel.prod() / shell_mm;
  const openvdb::Coord lo(int(std::floor(c.x() - tool_radius_index_.x() - 1)),
                          int(std::floor(c.y() - tool_radius_index_.y() - 1)),
                          int(std::floor(c.z() - tool_radius_index_.z() - 1)));
  const openvdb::Coord hi(int(std::ceil(c.x() + tool_radius_index_.x() + 1)),
                          int(std::ceil(c.y() + tool_radius_index_.y() + 1)),
                          int(std::ceil(c.z() + tool_radius_index_.z() + 1)));
  for (int i = lo.x(); i <= hi.x(); ++i) {
    for (int j = lo.y(); j <= hi.y(); ++j) {
      for (int k = lo.z(); k <= hi.z(); ++k) {
        const float rho = s.accessor().getValue(openvdb::Coord(i, j, k));
        const Vec3d r = field_->direction() * (Vec3d(i, j, k) - c).cwiseProduct(voxel);
        const double dist = r.norm();
        if (rho > 0.0f && std::abs(dist - radius_mm) <= 0.5 * shell_mm && dist > 0.0) {
          result.area_vector_mm2 += rho * area_per_voxel * (r / dist);
          result.contact_area_mm2 += rho * area_per_voxel;
          ++result.samples_in_contact;
        }
      }
    }
  }
  return result;
}

}  // namespace hapvox::engine
