#include "engine/material.h"

#include <cmath>
#include <sstream>

#include "engine/errors.h"

namespace hapvox::engine {

void validate_material(const ElasticMaterial& material, const std::string& e_source,
                       const std::string& nu_source) {
  const double e = material.youngs_modulus_pa;
  const double nu = material.poisson_ratio;
  if (!std::isfinite(e) || e <= 0.0) {
    std::ostringstream out;
    out << "Young's modulus must be positive and finite, got " << e << " Pa";
    throw InputError(e_source, out.str());
  }
  // nu = 0.5 is incompressible: lambda diverges, so the open interval is the valid range.
  if (!std::isfinite(nu) || nu <= -1.0 || nu >= 0.5) {
    std::ostringstream out;
    out << "Poisson's ratio must lie in (-1, 0.5), got " << nu;
    throw InputError(nu_source, out.str());
  }
}

LameParameters lame_parameters(const ElasticMaterial& material) {
  validate_material(material, "material", "material");
  const double e = material.youngs_modulus_pa;
  const double nu = material.poisson_ratio;
  return {e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu))};
}

}  // namespace hapvox::engine
