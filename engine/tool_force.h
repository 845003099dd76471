#pragma once
// Tool force: linear elasticity (Prados, Leon Salas & Torres, "Interactive elastic
// deformation of 3D images", Eq. 4-8) and, optionally, incremental plasticity (Prados et
// al., "Volumetric plastic deformation", section 4.2), as pinned down in docs/physics.md:
//
//   contact      some density under the tool's surface (Eq. 7), sampled trilinearly;
//   x0           the last contact-free tool centre, refined by bisection between ticks;
//   contact      the tool's surface reaches the material's nominal surface (density
//                surface_density, 1/2 by default: where a voxel ramp crosses half);
//   x0           the last contact-free tool centre, refined by bisection between ticks;
//   strain       compression along the push u = x_n - x0 over a reference length L (mm):
//                  Hertz law (default)  eps = -(|u|/L)(u_hat u_hat^T - nu (I - u_hat u_hat^T))
//                                       (free lateral expansion), with
//                                       L = 3/4 (1 - nu^2) |N| / a,  a = sqrt(S / 2 pi)
//                                       measured from the contact integral, so a sphere
//                                       on a half-space gives F = 4/3 E* sqrt(R) d^1.5;
//                  paper law            eps = -(|u|/L) u_hat u_hat^T, L fixed (the radius);
//   stress       Eq. 6: sigma = lambda tr(eps) I + 2 mu eps   (Pa)
//   force        Eq. 8 as a surface integral over the tool's contacting surface:
//                  F = sigma * N,  N = sum_k rho_k n_k dA_k     (mm^2; F in N after 1e-6)
//                zero when u points out of the material (u . N <= 0): contact pushes only;
//   plasticity   yield when s = E |u| / L exceeds sigma_f while the tool moves into the
//                material: x0 moves along the push (return mapping, slope E_ep), sigma_f
//                hardens, a SurfaceChange is emitted. Moving out is elastic unloading.
//
// Model (const, shared) / state (mutable, one per thread), MuJoCo-style: step() is the
// readable sequence of stages, each also public for tests and benchmarks. step() does not
// allocate, lock, throw or do I/O.

#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "engine/density_field.h"
#include "engine/material.h"
#include "engine/surface_change.h"

namespace hapvox::engine {

struct SphereTool {
  double diameter_mm = 8.0;
};

/// Incremental plasticity (Prados et al. 2011b): elastic slope E up to the yield stress
/// sigma_f, elasto-plastic load slope E_ep (0 <= E_ep < E; E_ep > 0 is linear hardening,
/// raising sigma_f), elastic unload with slope E.
struct PlasticMaterial {
  bool enabled = false;
  double yield_stress_pa = 10e3;  // on the mean contact pressure F / |N| (docs/physics.md)
  double elastoplastic_modulus_pa = 0.0;
};

/// How the strain's reference length L is chosen (docs/physics.md, "Contact law").
enum class ContactLaw : std::uint8_t {
  /// L from the contact integral, strain with free lateral expansion: Hertz at small
  /// indentation, right in E, nu, tool size and independent of the voxel size.
  kHertz = 0,
  /// The paper's fixed L (ToolForceOptions::reference_length_mm, 0: the tool radius) and
  /// uniaxial strain (shear components obviated): the normal stiffness is lambda + 2 mu.
  kPaper,
};

/// "hertz" or "paper".
const char* contact_law_name(ContactLaw law);

enum class PlasticZone : std::uint8_t { kNoContact = 0, kElastic, kPlasticLoad, kPlasticUnload };

struct ToolForceOptions {
  SphereTool tool;
  ElasticMaterial material;
  PlasticMaterial plastic;
  ContactLaw contact_law = ContactLaw::kHertz;
  /// L in the paper law's strain; 0 selects the tool radius (strain = indentation /
  /// radius). The Hertz law measures L from each contact, so this must stay 0 there.
  double reference_length_mm = 0.0;
  /// Density of the material's nominal surface: contact (and the indentation) starts where
  /// the tool's surface reaches it. 1/2 puts it on the voxel faces of a full/empty edge.
  double surface_density = 0.5;
  /// Target spacing of the surface quadrature points, in units of the smallest voxel size.
  double sample_spacing_voxels = 1.0;
  int min_surface_samples = 256;
  int max_surface_samples = 4096;
  /// Stick-slip limit on the contact origin (hapvox's extension, docs/physics.md): x0
  /// follows the tool tangentially once the tangential displacement exceeds
  /// slip_ratio x the normal indentation. Infinity (or < 0) keeps the paper's fixed x0.
  double slip_ratio = 0.5;
  /// Bisection steps that locate x0 between the last free and the first contact position.
  int onset_refinement_steps = 6;
};

/// N = sum of density-weighted outward normal x area over the tool's surface samples.
struct ContactIntegral {
  Vec3d area_vector_mm2 = Vec3d::Zero();
  double contact_area_mm2 = 0.0;  // S: sum of density x area (a scalar contact measure)
  int samples_in_contact = 0;     // samples with density > 0
  float max_density = 0.0f;       // largest sampled density (contact: >= surface_density)
  /// Hertz contact radius a = sqrt(S / 2 pi) (mm): a spherical cap of depth d has S =
  /// 2 pi R d, so a^2 = R d; for two curved surfaces it gives a^2 = R* d.
  double contact_radius_mm() const;
};

/// Per-thread mutable state of the elastic force model.
struct ToolForceState {
  explicit ToolForceState(const DensityField& field);
  /// For a field kept in two buffers with the same geometry (buffer 0, buffer 1).
  ToolForceState(const DensityField& buffer0, const DensityField& buffer1);

  // Carried between steps.
  bool has_position = false;
  bool in_contact = false;
  Vec3d last_position_mm = Vec3d::Zero();
  Vec3d contact_origin_mm = Vec3d::Zero();  // x0

  // Results of the last step.
  Vec3d displacement_mm = Vec3d::Zero();  // u = x_n - x0
  double indentation_mm = 0.0;            // u . n, n = N / |N| (into the material)
  double reference_length_mm = 0.0;       // L of this step's strain (0 out of contact)
  Eigen::Matrix3d stress_pa = Eigen::Matrix3d::Zero();
  ContactIntegral contact;
  Vec3d force_n = Vec3d::Zero();

  // Plasticity (per contact; reset when contact ends).
  PlasticZone zone = PlasticZone::kNoContact;
  double yield_stress_pa = 0.0;    // current sigma_f (hardened)
  double plastic_strain = 0.0;     // accumulated plastic strain of this contact
  double strain = 0.0;             // total strain |u|/L + plastic strain
  double stress_measure_pa = 0.0;  // s = E |u| / L, the scalar the yield rule uses
  bool surface_change_emitted = false;
  SurfaceChange surface_change;
  std::uint64_t plastic_steps = 0;

  // Counters (problems are counted, never logged, on the force path).
  std::uint64_t steps = 0;
  std::uint64_t contact_onsets = 0;
  std::uint64_t started_in_contact = 0;
  std::uint64_t nonfinite_forces = 0;

  // Read cache: accessors owned by this thread (one per field buffer it may read, made
  // before the loop starts: making one later would allocate), plus the last leaf found.
  std::array<openvdb::FloatGrid::ConstAccessor, 2> accessors;
  int active_buffer = 0;
  const openvdb::FloatTree::LeafNodeType* cached_leaf = nullptr;
  openvdb::Coord cached_leaf_origin{openvdb::Coord::max()};
  float cached_tile_value = 0.0f;

  /// Call after the field this state reads has been changed (lockstep only).
  void invalidate_cache() {
    accessors[active_buffer].clear();
    cached_leaf = nullptr;
    cached_leaf_origin = openvdb::Coord::max();
  }
  /// Reads buffer 0 or 1 from now on (double-buffered fields in realtime runs). Does not
  /// allocate.
  void read_from(int buffer) {
    if (buffer == active_buffer) return;
    active_buffer = buffer;
    invalidate_cache();
  }
  openvdb::FloatGrid::ConstAccessor& accessor() { return accessors[active_buffer]; }
};

class ToolForceModel {
 public:
  /// Validates the options (throws InputError on a bad material or tool) and precomputes
  /// the surface quadrature. `field` must outlive the model.
  ToolForceModel(const DensityField& field, const ToolForceOptions& options);

  ToolForceState make_state() const { return ToolForceState(*field_); }
  /// A state that can read `field()` as buffer 0 and `second` (same geometry) as buffer 1.
  ToolForceState make_state(const DensityField& second) const {
    return ToolForceState(*field_, second);
  }

  /// One force tick at tool centre `tool_center_mm` (volume space). Fills state's results.
  void step(const Vec3d& tool_center_mm, ToolForceState& state) const;

  // --- Stages of step(), in order. ---
  /// Surface integral of density-weighted normals at this tool position.
  ContactIntegral integrate_contact(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// Contact test only (Eq. 7): stops at the first sample at the nominal surface.
  bool touches(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// x0 between a contact-free position and a touching one, by bisection.
  Vec3d refine_contact_origin(const Vec3d& free_mm, const Vec3d& touching_mm,
                              ToolForceState& state) const;
  /// Moves x0 tangentially so |u_t| <= slip_ratio |u_n| (n from the contact integral).
  Vec3d slide_contact_origin(const Vec3d& tool_center_mm, const Vec3d& origin_mm,
                             const ContactIntegral& contact) const;
  /// Return mapping of the incremental plasticity: updates x0, sigma_f and the zone, and
  /// emits a SurfaceChange on a plastic step. Flow only while the tool moves into the
  /// material (state.last_position_mm -> tool_center_mm against the contact normal) with u
  /// pointing in; otherwise elastic. Plasticity disabled: only the zone and measures.
  void apply_plasticity(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// L of the strain for this contact (mm): the paper's fixed length, or the Hertz law's
  /// 3/4 (1 - nu^2) |N| / a. 0 when the contact has no area vector.
  double reference_length_mm(const ContactIntegral& contact) const;
  /// Eq. 6 for the law's strain of displacement u over length L (Pa). Zero for L <= 0.
  Eigen::Matrix3d stress_pa(const Vec3d& displacement_mm, double reference_length_mm) const;
  /// Eq. 8: F = sigma N (N).
  static Vec3d traction_force_n(const Eigen::Matrix3d& stress_pa, const ContactIntegral& contact);

  /// The seed's approach, for benchmarks: every voxel of the tool's bounding box read
  /// through a ValueAccessor; voxels whose centre lies within half a voxel of the sphere
  /// contribute density x normal x area. Same quantity as integrate_contact, coarser.
  ContactIntegral integrate_contact_naive(const Vec3d& tool_center_mm, ToolForceState& state) const;

  const ToolForceOptions& options() const { return options_; }
  const LameParameters& lame() const { return lame_; }
  /// The paper law's fixed L (mm); 0 for the Hertz law, whose L comes from each contact.
  double fixed_reference_length_mm() const { return fixed_reference_length_mm_; }
  double tool_radius_mm() const { return 0.5 * options_.tool.diameter_mm; }
  int surface_sample_count() const { return static_cast<int>(sample_offsets_index_.size()); }
  const DensityField& field() const { return *field_; }

 private:
  float sample_density(const Eigen::Vector3f& q_index, ToolForceState& state) const;
  bool may_touch(const Vec3d& center_index) const;

  const DensityField* field_;
  ToolForceOptions options_;
  LameParameters lame_;
  double fixed_reference_length_mm_;  // paper law only
  double hertz_length_factor_;        // 3/4 (1 - nu^2)
  float surface_density_;
  double sample_area_mm2_;
  Vec3d tool_radius_index_;  // radius in index units per axis
  // Quadrature points relative to the tool centre: offset in index units and the
  // outward unit normal, ordered so consecutive points fall in the same leaf.
  std::vector<Eigen::Vector3f> sample_offsets_index_;
  std::vector<Eigen::Vector3f> sample_normals_;
  openvdb::CoordBBox active_bbox_;  // index bbox of all active voxels, grown by 1
};

}  // namespace hapvox::engine
