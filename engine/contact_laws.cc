// The two contact laws' forces, friction and plasticity, for a contact whose origin x0 is
// set (tool_force.h; docs/physics.md, "Contact law", "Friction", "Incremental plasticity").

#include <algorithm>
#include <cmath>
#include <numbers>

#include "engine/tool_force.h"

namespace hapvox::engine {
namespace {

constexpr double kNewtonPerPaMm2 = 1e-6;  // 1 Pa x 1 mm^2 = 1e-6 N
// |N| / S below which N has no direction: a cap of the sphere's surface outside the
// material of less than 1 % of its radius in height (|N| / S = delta / 2R near burial).
constexpr double kDefinedNormalShare = 0.005;

// Both laws' stick-slip: x0 moves in the plane normal to `normal` (unit) until the tool's
// tangential displacement from it is at most t_max_mm; unchanged while it is (sticking).
Vec3d slip_across(const Vec3d& x_mm, const Vec3d& origin_mm, const Vec3d& normal, double t_max_mm) {
  const Vec3d u = x_mm - origin_mm;
  const Vec3d u_tangent = u - u.dot(normal) * normal;
  const double t_length = u_tangent.norm();
  if (t_length <= t_max_mm) return origin_mm;                  // sticking
  return origin_mm + u_tangent * (1.0 - t_max_mm / t_length);  // slipping: on the bound
}

}  // namespace

void ToolForceModel::update_contact_normal(ToolForceState& s) const {
  // The contact normal, where N says where the material is: a tool nearly buried in
  // uniform material has N ~ 0 (all round, the normals cancel) and a direction that is
  // only the quadrature's residue. There it keeps the last normal it had, so its force
  // stays continuous and its origin slips in a plane that means something.
  const double n_length = s.contact.area_vector_mm2.norm();
  if (n_length > kDefinedNormalShare * s.contact.contact_area_mm2) {
    s.normal = s.contact.area_vector_mm2 / n_length;
  }
}

void ToolForceModel::apply_contact_law(const Vec3d& x_mm, ToolForceState& s) const {
  s.slipping = false;
  if (options_.contact_law == ContactLaw::kHertz) {
    // Near the surface, where it is (contact_surface.cc): the contact radius of a pole
    // still inside the density ramp, and x0 along n for an elastic contact.
    if (s.plastic_strain == 0.0) {
      const PoleDepth pole = pole_depth(x_mm, s.normal, s);
      s.ramp_factor = pole.ramp_factor;
      if (pole.surface_found) follow_surface(x_mm, pole.depth_mm, s);
    }
    s.contact.ramp_factor = plastic_ramp_factor(s);
    hertz_force(x_mm, s);
  } else {
    paper_force(x_mm, s);
  }
  if (!s.force_n.allFinite()) {
    ++s.nonfinite_forces;
    s.force_n.setZero();
  }
  if (s.surface_change_emitted) {
    // The tool centre on the new surface, after this step's slip.
    s.surface_change.from_mm = s.contact_origin_mm;
    s.surface_change.position_mm = s.contact_origin_mm;
  }
}

double ToolForceModel::plastic_ramp_factor(const ToolForceState& s) const {
  if (s.plastic_strain == 0.0) return s.ramp_factor;
  // Under plastic flow the tool presses material it is itself displacing, which the
  // relaxation rewrites at every voxel it crosses: the undisturbed ramp the lines read is
  // gone. The correction at yield fades as x0 flows on, over one voxel of flow, by when
  // the cap lies past any ramp (continuous at yield, and with no ripple at the
  // voxel-crossing rate).
  const double share = std::min(1.0, s.plastic_flow_mm / field_->voxel_size_mm().minCoeff());
  return s.ramp_factor + share * (1.0 - s.ramp_factor);
}

void ToolForceModel::follow_surface(const Vec3d& x_mm, double depth_mm, ToolForceState& s) const {
  // The onset read the surface once, at the bisection's position and with the first
  // tick's n (from the few quadrature points then in the ramp); later ticks read it again
  // (measured: validate hertz's diagonal presses on 0.5 mm voxels go from 0.977 to 0.985 of
  // Hertz with R*, the binary ones from 1.36 to 1.25). Moving x0's normal part (not its
  // tangential part, which friction owns) by at most 1/50 voxel a tick keeps the force
  // continuous where the line through the pole starts or stops finding the surface.
  const double h_mm = field_->voxel_size_mm().minCoeff();
  // Only near the surface: a line off n (contact_surface.cc) reads a curved surface
  // shallower by (offset)^2 / 2 R_m, which grows with the depth.
  if (depth_mm > 0.5 * h_mm) return;
  const double max_step_mm = 0.02 * h_mm;
  const double error_mm = (x_mm - s.contact_origin_mm).dot(s.normal) - depth_mm;
  s.contact_origin_mm += std::clamp(error_mm, -max_step_mm, max_step_mm) * s.normal;
}

void ToolForceModel::hertz_force(const Vec3d& x_mm, ToolForceState& s) const {
  // Plastic flow first (it moves x0 along n only), then the normal force of the settled
  // indentation, then friction bounded by that normal force.
  apply_plasticity(x_mm, s);
  const Vec3d& n = s.normal;
  s.normal_force_n = hertz_normal_force_n(s.contact, (x_mm - s.contact_origin_mm).dot(n));
  const double k_t = tangential_stiffness_n_per_mm(s.contact);
  const Vec3d origin = slip_contact_origin(x_mm, s.contact_origin_mm, n, k_t, s.normal_force_n);
  s.slipping = origin != s.contact_origin_mm;
  s.contact_origin_mm = origin;
  const Vec3d u = x_mm - origin;
  s.indentation_mm = u.dot(n);  // a slip is tangential: d is unchanged
  if (!(s.indentation_mm > 0.0)) {
    // Off the surface: no force, and no elastic deformation to show (the FFD reads u).
    s.displacement_mm.setZero();
    s.stress_pa.setZero();
    s.friction_force_n.setZero();
    s.force_n.setZero();
    return;
  }
  s.displacement_mm = u;
  s.friction_force_n = -k_t * (u - s.indentation_mm * n);
  s.force_n = -s.normal_force_n * n + s.friction_force_n;
  // The contact's mean pressure as a uniaxial stress along n (what the yield rule reads).
  s.stress_pa = -hertz_mean_pressure_pa(s.contact, s.indentation_mm) * (n * n.transpose());
}

void ToolForceModel::paper_force(const Vec3d& x_mm, ToolForceState& s) const {
  s.reference_length_mm = fixed_reference_length_mm_;
  s.contact_origin_mm = slide_contact_origin(x_mm, s.contact_origin_mm, s.contact);
  apply_plasticity(x_mm, s);
  s.displacement_mm = x_mm - s.contact_origin_mm;
  s.indentation_mm = s.displacement_mm.dot(s.normal);
  if (!(s.indentation_mm > 0.0)) {
    // Contact only pushes: a tool beyond x0 (u . n <= 0) is off the surface.
    s.displacement_mm.setZero();
    s.stress_pa.setZero();
    s.force_n.setZero();
  } else if (tissue_ == nullptr) {
    s.stress_pa = stress_pa(s.displacement_mm, s.reference_length_mm);
    s.force_n = traction_force_n(s.stress_pa, s.contact);
  } else {
    // Each point's own material; the reported stress is the contact's mean material's.
    const double nu = contact_poisson_ratio(s.contact);
    const double e = contact_youngs_modulus_pa(s.contact);
    const Eigen::Matrix3d eps = strain(s.displacement_mm, s.reference_length_mm);
    const double lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    const double mu = e / (2.0 * (1.0 + nu));
    s.stress_pa = lambda * eps.trace() * Eigen::Matrix3d::Identity() + 2.0 * mu * eps;
    s.force_n = tissue_force_n(eps, s.contact);
  }
  // The paper's force is one vector along -u: report its parts along and across n.
  s.normal_force_n = std::max(0.0, -s.force_n.dot(s.normal));
  s.friction_force_n = s.force_n - s.force_n.dot(s.normal) * s.normal;
}

double ToolForceModel::hertz_normal_force_n(const ContactIntegral& contact,
                                            double indentation_mm) const {
  if (!(indentation_mm > 0.0)) return 0.0;
  const double nu = contact_poisson_ratio(contact);
  const double e_star = contact_youngs_modulus_pa(contact) / (1.0 - nu * nu);
  return 4.0 / 3.0 * e_star * contact.contact_radius_mm() * indentation_mm * kNewtonPerPaMm2;
}

double ToolForceModel::hertz_mean_pressure_pa(const ContactIntegral& contact,
                                              double indentation_mm) const {
  const double a_mm = contact.contact_radius_mm();
  if (!(a_mm > 0.0)) return 0.0;
  const double area_mm2 = std::numbers::pi * a_mm * a_mm;
  return hertz_normal_force_n(contact, indentation_mm) / (area_mm2 * kNewtonPerPaMm2);
}

double ToolForceModel::tangential_stiffness_n_per_mm(const ContactIntegral& contact) const {
  const double nu = contact_poisson_ratio(contact);
  const double shear_pa = contact_youngs_modulus_pa(contact) / (2.0 * (1.0 + nu));
  const double a_mm = 0.5 * tool_radius_mm();
  return 8.0 * shear_pa * a_mm / (2.0 - nu) * kNewtonPerPaMm2;
}

Vec3d ToolForceModel::slip_contact_origin(const Vec3d& x_mm, const Vec3d& origin_mm,
                                          const Vec3d& normal, double stiffness_n_per_mm,
                                          double normal_force_n) const {
  const double mu = options_.friction_coefficient;
  if (std::isinf(mu) || !(stiffness_n_per_mm > 0.0)) return origin_mm;  // never slips
  // No contact normal (a tool buried in uniform material, N = 0): no plane to slip in, and
  // the origin stays where the tool left the surface.
  if (!(normal.squaredNorm() > 0.0)) return origin_mm;
  return slip_across(x_mm, origin_mm, normal,
                     mu * std::max(0.0, normal_force_n) / stiffness_n_per_mm);
}

Vec3d ToolForceModel::slide_contact_origin(const Vec3d& x_mm, const Vec3d& origin_mm,
                                           const ContactIntegral& contact) const {
  const double ratio = options_.friction_coefficient;
  const double n_length = contact.area_vector_mm2.norm();
  if (!(ratio >= 0.0) || std::isinf(ratio) || !(n_length > 0.0)) return origin_mm;
  // N points from the tool into the material: the direction of a normal press.
  const Vec3d inward = contact.area_vector_mm2 / n_length;
  return slip_across(x_mm, origin_mm, inward,
                     ratio * std::max(0.0, (x_mm - origin_mm).dot(inward)));
}

double ToolForceModel::contact_youngs_modulus_pa(const ContactIntegral& contact) const {
  if (tissue_ == nullptr || !(contact.contact_area_mm2 > 0.0)) {
    return options_.material.youngs_modulus_pa;
  }
  return contact.modulus_area_pa_mm2 / contact.contact_area_mm2;
}

double ToolForceModel::contact_poisson_ratio(const ContactIntegral& contact) const {
  if (tissue_ == nullptr || !(contact.contact_area_mm2 > 0.0)) {
    return options_.material.poisson_ratio;
  }
  return contact.poisson_area_mm2 / contact.contact_area_mm2;
}

double ToolForceModel::contact_yield_stress_pa(const ContactIntegral& contact) const {
  if (tissue_ == nullptr || !(contact.contact_area_mm2 > 0.0)) {
    return options_.plastic.yield_stress_pa;
  }
  return contact.yield_area_pa_mm2 / contact.contact_area_mm2;
}

Eigen::Matrix3d ToolForceModel::strain(const Vec3d& u, double reference_length_mm) {
  const double length = u.norm();
  if (!(length > 0.0) || !(reference_length_mm > 0.0)) return Eigen::Matrix3d::Zero();
  // Compression |u| / L along the push, no lateral strain (the seed's uniaxial strain).
  const Vec3d dir = u / length;
  return -length / reference_length_mm * (dir * dir.transpose());
}

Eigen::Matrix3d ToolForceModel::stress_pa(const Vec3d& u, double reference_length_mm) const {
  const Eigen::Matrix3d eps = strain(u, reference_length_mm);
  return lame_.lambda_pa * eps.trace() * Eigen::Matrix3d::Identity() + 2.0 * lame_.mu_pa * eps;
}

Vec3d ToolForceModel::traction_force_n(const Eigen::Matrix3d& stress,
                                       const ContactIntegral& contact) {
  // The tool's outward normal is the inward normal of the material it presses, so the
  // material pushes on the tool with sigma n dA integrated over the contact.
  return stress * contact.area_vector_mm2 * kNewtonPerPaMm2;
}

Vec3d ToolForceModel::tissue_force_n(const Eigen::Matrix3d& eps, const ContactIntegral& contact) {
  // sum_k (lambda_k tr(eps) I + 2 mu_k eps) n_k dA_k, the strain being the contact's.
  return (eps.trace() * contact.lambda_area_vector_pa_mm2 +
          2.0 * eps * contact.mu_area_vector_pa_mm2) *
         kNewtonPerPaMm2;
}

void ToolForceModel::apply_plasticity(const Vec3d& x_mm, ToolForceState& s) const {
  const double e = contact_youngs_modulus_pa(s.contact);
  const bool hertz = options_.contact_law == ContactLaw::kHertz;
  const Vec3d& n = s.normal;
  // The yield rule's measure for origin x0: the Hertz mean pressure of the indentation, or
  // the paper's E |u| / L; zero for a tool beyond x0 (u . n <= 0), which carries no stress.
  auto measure = [&](const Vec3d& origin_mm) {
    const Vec3d u = x_mm - origin_mm;
    const double d = u.dot(n);
    if (!(d > 0.0)) return 0.0;
    if (hertz) return hertz_mean_pressure_pa(s.contact, d);
    return s.reference_length_mm > 0.0 ? e * u.norm() / s.reference_length_mm : 0.0;
  };
  const double trial_stress = measure(s.contact_origin_mm);
  if (!options_.plastic.enabled) {
    s.zone = PlasticZone::kElastic;
    s.stress_measure_pa = trial_stress;
    s.strain = trial_stress / e;
    return;
  }
  const double previous_stress = s.stress_measure_pa;
  // Loading is judged by the stress, not by the tool's velocity: a trial state beyond the
  // yield surface flows whichever way the tool moved (a sideways stroke loads too); a
  // falling measure is elastic unloading.
  if (trial_stress > s.yield_stress_pa) {
    // Both measures are proportional, at this tick's contact, to the distance x0 lies
    // behind the tool along the flow direction (d along n, |u| along u), so a strain step
    // of the measure (s / E) is E distance / s of that distance.
    const Vec3d u = x_mm - s.contact_origin_mm;
    const Vec3d direction = hertz ? n : Vec3d(u.normalized());
    const double distance_mm = u.dot(direction);
    flow(trial_stress, e, direction, e * distance_mm / trial_stress, s);
  } else if (s.plastic_strain > 0.0 &&
             (trial_stress < previous_stress || s.zone == PlasticZone::kPlasticUnload)) {
    s.zone = PlasticZone::kPlasticUnload;
  } else if (s.plastic_strain == 0.0) {
    s.zone = PlasticZone::kElastic;
  }
  s.stress_measure_pa = measure(s.contact_origin_mm);
  s.strain = s.stress_measure_pa / e + s.plastic_strain;
}

void ToolForceModel::flow(double trial_stress_pa, double e_pa, const Vec3d& direction,
                          double displacement_per_strain_mm, ToolForceState& s) const {
  const double e_ep = options_.plastic.elastoplastic_modulus_pa;
  // Hardening modulus H of the plastic strain that gives the tangent slope E_ep.
  const double hardening = e_pa * e_ep / (e_pa - e_ep);
  const double plastic_strain = (trial_stress_pa - s.yield_stress_pa) / (e_pa + hardening);
  s.yield_stress_pa += hardening * plastic_strain;
  s.plastic_strain += plastic_strain;
  // The surface moves permanently: x0 follows the push by the plastic displacement.
  s.contact_origin_mm += direction * (plastic_strain * displacement_per_strain_mm);
  s.plastic_flow_mm += std::abs(plastic_strain * displacement_per_strain_mm);
  s.zone = PlasticZone::kPlasticLoad;
  s.surface_change_emitted = true;
  s.surface_change.direction = direction;
  s.surface_change.radius_mm = tool_radius_mm();
  ++s.plastic_steps;
}

}  // namespace hapvox::engine
