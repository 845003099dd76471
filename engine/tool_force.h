#pragma once
// Tool force on a sphere from a density volume (docs/physics.md, "Contact law"):
//
//   contact      the tool's surface reaches the material's nominal surface (density
//                surface_density, 1/2 by default: where a voxel ramp crosses half);
//   x0           the contact origin: the last contact-free tool centre, refined by
//                bisection between ticks (the Hertz law: then along n to where the pole
//                meets the surface, contact_surface.cc), then moved by friction slip and
//                plastic flow;
//   N, S         N = sum_k rho_k n_k dA_k (mm^2, into the material), S = sum_k rho_k dA_k
//                over the tool's surface samples, read trilinearly;
//   Hertz law (default)
//     normal     indentation d = (x - x0) . n, n = N / |N|, contact radius
//                a = sqrt(c S / 2 pi) (c < 1 corrects S while the pole is in the ramp):
//                  F_n = 4/3 E* a d  along -n  (E* = E / (1 - nu^2)),
//                so a sphere on a half-space gives F = 4/3 E* sqrt(R) d^1.5, and a sphere on
//                a sphere (a^2 = R* d) Hertz with R*; F_n depends on the position only
//                through d and a: conservative on any face where a is a function of d;
//     friction   Coulomb: a tangential spring k_t (Mindlin's 8 G a / (2 - nu) at a = R/2)
//                from x0, F_t = -k_t u_t, |F_t| <= mu F_n; beyond, x0 slips. The normal
//                force does not depend on u_t;
//     plasticity yield when the Hertz mean pressure p = F_n / (pi a^2) = 4 E* d / (3 pi a)
//                of the trial state exceeds sigma_f (loading is judged by the stress, not
//                the tool's velocity): x0 moves along n (return mapping, slope E_ep),
//                sigma_f hardens, a SurfaceChange is emitted.
//   paper law    Prados, Leon Salas & Torres, "Interactive elastic deformation of 3D images",
//                Eq. 4-8: eps = -(|u|/L) u_hat u_hat^T with u = x - x0 and L fixed,
//                sigma = lambda tr(eps) I + 2 mu eps, F = sigma N (1e-6 N per Pa mm^2);
//                x0 slips tangentially once |u_t| > mu u_n (the force's friction cone);
//                yield on s = E |u| / L (Prados et al., "Volumetric plastic deformation").
//   tissue       with a TissueMap (tissue_map.h), each quadrature point has its own
//                material: the paper law integrates lambda and mu point by point, the
//                Hertz law uses the contact's density-weighted mean E, nu and sigma_f.
//
// Model (const, shared) / state (mutable, one per thread), MuJoCo-style: step() is the
// readable sequence of stages, each also public for tests and benchmarks. step() does not
// allocate, lock, throw or do I/O.

#include <openvdb/openvdb.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "engine/density_field.h"
#include "engine/leaf_window.h"
#include "engine/material.h"
#include "engine/stencil_cache.h"
#include "engine/surface_change.h"
#include "engine/tissue_map.h"

namespace hapvox::engine {

struct SphereTool {
  double diameter_mm = 8.0;
};

/// Incremental plasticity (Prados et al. 2011b): elastic slope E up to the yield stress
/// sigma_f, elasto-plastic load slope E_ep (0 <= E_ep < E; E_ep > 0 is linear hardening,
/// raising sigma_f), elastic unload with slope E.
struct PlasticMaterial {
  bool enabled = false;
  /// sigma_f on the Hertz mean pressure F_n / (pi a^2) (the paper law: on E |u| / L).
  double yield_stress_pa = 10e3;
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
  /// Coulomb friction coefficient mu (docs/physics.md, "Friction"): the tangential force is
  /// at most mu x the normal force; beyond it the contact origin slips. Under the paper law,
  /// the bound on the force's angle (|u_t| <= mu u_n). Infinity: the contact never slips
  /// (the paper's fixed x0). The command line refuses a negative or NaN coefficient.
  double friction_coefficient = 0.5;
  /// Bisection steps that locate x0 between the last free and the first contact position.
  int onset_refinement_steps = 6;
};

/// N = sum of density-weighted outward normal x area over the tool's surface samples.
struct ContactIntegral {
  Vec3d area_vector_mm2 = Vec3d::Zero();
  double contact_area_mm2 = 0.0;  // S: sum of density x area (a scalar contact measure)
  int samples_in_contact = 0;     // samples with density > 0
  float max_density = 0.0f;       // largest sampled density (contact: >= surface_density)
  // With a TissueMap (else zero): the same integral weighted by each point's material,
  // the material at a point being its trilinear stencil's, each corner weighted by its
  // trilinear weight times its density (so empty voxels lend no material).
  Vec3d lambda_area_vector_pa_mm2 = Vec3d::Zero();  // sum lambda rho n dA
  Vec3d mu_area_vector_pa_mm2 = Vec3d::Zero();      // sum mu rho n dA
  double modulus_area_pa_mm2 = 0.0;                 // sum E rho dA
  double poisson_area_mm2 = 0.0;                    // sum nu rho dA
  double yield_area_pa_mm2 = 0.0;                   // sum sigma_f rho dA
  /// The depth the surface stands above the pole over the depth S's cap reads (1 once
  /// the pole is past the density ramp; PoleDepth). Set by the Hertz law.
  double ramp_factor = 1.0;
  /// Hertz contact radius a = sqrt(ramp_factor S / 2 pi) (mm): a spherical cap of depth d
  /// has S = 2 pi R d, so a^2 = R d; for two curved surfaces it gives a^2 = R* d.
  double contact_radius_mm() const;
};

/// The nominal surface below the tool's pole p = x + R n, from the density along the line
/// through p on the grid axis closest to n, 8 voxels out and 6 in (contact_surface.cc).
struct PoleDepth {
  /// depth_mm holds the pole's depth below the surface: the line starts outside the
  /// material and ends past its edge, in material at least surface_density dense.
  bool surface_found = false;
  /// Where the material on the line would begin if it were as dense as at its inner end,
  /// measured from there to the pole (> 0: the pole is inside).
  double depth_mm = 0.0;
  /// depth_mm over the depth the cap of S stands for (the line's density integrated up
  /// to the pole), in [0, 2]; 1 where the surface was not found.
  double ramp_factor = 1.0;
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
  double ramp_factor = 1.0;                 // PoleDepth's, while the contact is elastic
  double plastic_flow_mm = 0.0;             // how far x0 has flowed in this contact

  // Results of the last step.
  Vec3d displacement_mm = Vec3d::Zero();  // u = x_n - x0
  double indentation_mm = 0.0;            // d = u . n, n = N / |N| (into the material)
  // n of this step: N / |N|, kept from the last step where N had a direction (a buried
  // tool's N is the quadrature's residue); zero out of contact.
  Vec3d normal = Vec3d::Zero();
  double normal_force_n = 0.0;             // F_n, the magnitude of the force along -n
  Vec3d friction_force_n = Vec3d::Zero();  // F_t, tangential (Hertz law; zero under the paper's)
  bool slipping = false;                   // x0 slipped this step
  double reference_length_mm = 0.0;        // the paper law's L (0 under Hertz's, out of contact)
  Eigen::Matrix3d stress_pa = Eigen::Matrix3d::Zero();
  ContactIntegral contact;
  Vec3d force_n = Vec3d::Zero();

  // Plasticity (per contact; reset when contact ends).
  PlasticZone zone = PlasticZone::kNoContact;
  double yield_stress_pa = 0.0;    // current sigma_f (hardened)
  double plastic_strain = 0.0;     // accumulated plastic strain of this contact
  double strain = 0.0;             // total strain: s / E + plastic strain
  double stress_measure_pa = 0.0;  // s, the scalar the yield rule uses (Hertz: mean pressure)
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
  // The leaves around the tool in a table (leaf_window.h), sized by make_state.
  // use_read_caches false reads every point through the accessor instead, as before
  // issue 29 (the tests compare the two: the forces are bit-identical).
  bool use_read_caches = true;
  LeafWindow window;
  // Each quadrature point's stencil, kept between ticks (stencil_cache.h), and the
  // points' densities of the last integral; both sized by make_state.
  StencilCache stencils;
  std::vector<float> sample_densities;
  // The tissue slots, when the model has a TissueMap (made by ToolForceModel::make_state).
  std::optional<openvdb::Int32Grid::ConstAccessor> tissue_accessor;

  /// Call after the field this state reads has been changed (lockstep only).
  void invalidate_cache() {
    accessors[active_buffer].clear();
    cached_leaf = nullptr;
    cached_leaf_origin = openvdb::Coord::max();
    window.invalidate();
    stencils.invalidate();
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
  /// the surface quadrature. `field` (and `tissue`, when given) must outlive the model.
  /// With `tissue`, its materials replace options.material (its row 0 stands for voxels no
  /// label gave a material) and their yield stresses options.plastic.yield_stress_pa.
  ToolForceModel(const DensityField& field, const ToolForceOptions& options,
                 const TissueMap* tissue = nullptr);

  ToolForceState make_state() const;
  /// A state that can read `field()` as buffer 0 and `second` (same geometry) as buffer 1.
  ToolForceState make_state(const DensityField& second) const;

  /// One force tick at tool centre `tool_center_mm` (volume space). Fills state's results.
  void step(const Vec3d& tool_center_mm, ToolForceState& state) const;

  // --- Stages of step(), in order. ---
  /// Surface integral of density-weighted normals at this tool position.
  ContactIntegral integrate_contact(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// Contact test only (Eq. 7): stops at the first sample at the nominal surface.
  bool touches(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// The contact normal n = N / |N| of state.contact, kept where N has no direction.
  void update_contact_normal(ToolForceState& state) const;
  /// x0 between a contact-free position and a touching one, by bisection; the Hertz law
  /// then moves it along state.normal to where the pole meets the surface (pole_depth).
  Vec3d refine_contact_origin(const Vec3d& free_mm, const Vec3d& touching_mm,
                              ToolForceState& state) const;
  /// The surface below the pole of a tool at `tool_center_mm` along `normal` (unit, into
  /// the material): its depth, and the contact radius's correction inside the ramp.
  PoleDepth pole_depth(const Vec3d& tool_center_mm, const Vec3d& normal,
                       ToolForceState& state) const;
  /// The contact law's force at this tool position, after onset: friction slip, plastic
  /// flow, the force and the measures (engine/contact_laws.cc).
  void apply_contact_law(const Vec3d& tool_center_mm, ToolForceState& state) const;

  // --- The Hertz law's stages (docs/physics.md, "Contact law", "Friction"). ---
  /// 4/3 E* a d (N) for indentation d along the contact normal, a = sqrt(S / 2 pi); 0 for
  /// d <= 0.
  double hertz_normal_force_n(const ContactIntegral& contact, double indentation_mm) const;
  /// Hertz mean pressure F_n / (pi a^2) = 4 E* d / (3 pi a) (Pa); 0 for d <= 0 or a = 0.
  double hertz_mean_pressure_pa(const ContactIntegral& contact, double indentation_mm) const;
  /// k_t = 8 G a_t / (2 - nu) (N/mm), Mindlin's stiffness of a rigid sphere on an elastic
  /// half-space, at the fixed contact radius a_t = R / 2: a constant k_t keeps the normal
  /// force independent of the tangential stretch and a sticking contact conservative.
  double tangential_stiffness_n_per_mm(const ContactIntegral& contact) const;
  /// Coulomb slip of the contact origin: x0 moves in the plane normal to `normal` (unit,
  /// into the material) until k_t |u_t| <= mu F_n; unchanged while that holds (sticking).
  Vec3d slip_contact_origin(const Vec3d& tool_center_mm, const Vec3d& origin_mm,
                            const Vec3d& normal, double stiffness_n_per_mm,
                            double normal_force_n) const;
  /// The paper law's stick-slip of x0: tangentially until |u_t| <= mu u_n.
  Vec3d slide_contact_origin(const Vec3d& tool_center_mm, const Vec3d& origin_mm,
                             const ContactIntegral& contact) const;
  /// Return mapping of the incremental plasticity: when the trial stress measure exceeds
  /// the yield stress, x0 moves into the material until it is back on the (hardened) yield
  /// surface, and a SurfaceChange is emitted; a falling measure is elastic unloading. The
  /// measure is the Hertz mean pressure (Hertz law) or E |u| / L (paper law). Plasticity
  /// disabled: only the zone and measures.
  void apply_plasticity(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// The paper law's Eq. 6 for its strain of displacement u over length L (Pa), with the
  /// model's material. Zero for L <= 0.
  Eigen::Matrix3d stress_pa(const Vec3d& displacement_mm, double reference_length_mm) const;
  /// The paper law's strain of u over L: compression |u| / L along u, no lateral strain.
  /// Zero for L <= 0.
  static Eigen::Matrix3d strain(const Vec3d& displacement_mm, double reference_length_mm);
  /// Eq. 8: F = sigma N (N).
  static Vec3d traction_force_n(const Eigen::Matrix3d& stress_pa, const ContactIntegral& contact);
  /// Eq. 8 with the material at each quadrature point: F = 1e-6 (tr(eps) N_lambda + 2 eps
  /// N_mu) (N). Equals traction_force_n for one material.
  static Vec3d tissue_force_n(const Eigen::Matrix3d& strain, const ContactIntegral& contact);

  /// The contact's density-weighted mean E, nu and sigma_f with a TissueMap; the model's
  /// material (and options.plastic's sigma_f) without one, or when nothing is in contact.
  double contact_youngs_modulus_pa(const ContactIntegral& contact) const;
  double contact_poisson_ratio(const ContactIntegral& contact) const;
  double contact_yield_stress_pa(const ContactIntegral& contact) const;

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
  /// The materials by tissue, or nullptr (one material: options().material).
  const TissueMap* tissue() const { return tissue_; }

 private:
  float sample_density(const Eigen::Vector3f& q_index, ToolForceState& state) const;
  /// Sizes the state's read caches for this model's tool and quadrature.
  void reserve_caches(ToolForceState& state) const;
  /// Adds quadrature point q (index space, outward normal n, density > 0) to the tissue
  /// sums of `result` (before the area factor).
  void add_tissue_sample(const Eigen::Vector3f& q_index, const Eigen::Vector3f& normal,
                         ToolForceState& state, ContactIntegral& result) const;
  bool may_touch(const Vec3d& center_index) const;
  /// The two laws' forces for a contact whose x0 is set (contact_laws.cc).
  void hertz_force(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// Moves x0 along state.normal toward the place where the pole lies depth_mm below the
  /// surface, a fiftieth of a voxel at most (an elastic contact near the surface).
  void follow_surface(const Vec3d& tool_center_mm, double depth_mm, ToolForceState& state) const;
  /// The contact radius's correction: PoleDepth's while elastic; after yield, its value
  /// then, fading to 1 over one voxel of plastic flow.
  double plastic_ramp_factor(const ToolForceState& state) const;
  void paper_force(const Vec3d& tool_center_mm, ToolForceState& state) const;
  /// Moves x0 into the material by the plastic strain of a trial measure above the yield
  /// stress, hardens sigma_f and emits the SurfaceChange.
  void flow(double trial_stress_pa, double youngs_modulus_pa, const Vec3d& flow_direction,
            double displacement_per_strain_mm, ToolForceState& state) const;

  const DensityField* field_;
  const TissueMap* tissue_;
  ToolForceOptions options_;
  LameParameters lame_;
  double fixed_reference_length_mm_;  // paper law only
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
