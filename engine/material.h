#pragma once
// Linear-elastic isotropic material: Young's modulus E (Pa) and Poisson's ratio nu, and
// the Lame parameters they imply (Prados et al., Eq. 5-6).

#include <string>

namespace hapvox::engine {

struct ElasticMaterial {
  double youngs_modulus_pa = 100e3;  // soft clay / soft tissue order of magnitude
  double poisson_ratio = 0.3;
};

struct LameParameters {
  double lambda_pa = 0.0;
  double mu_pa = 0.0;
};

/// Throws hapvox::InputError unless E > 0 and finite and -1 < nu < 0.5; the error's source
/// is `e_source` or `nu_source` (a file, a flag) for the offending value.
void validate_material(const ElasticMaterial& material, const std::string& e_source,
                       const std::string& nu_source);

/// lambda = E nu / ((1 + nu)(1 - 2 nu)), mu = E / (2 (1 + nu)). Validates first.
LameParameters lame_parameters(const ElasticMaterial& material);

}  // namespace hapvox::engine
