#include "engine/tissue_map.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine {

TissueMap::TissueMap(std::vector<TissueMaterial> materials, openvdb::Int32Grid::Ptr slots)
    : materials_(std::move(materials)), slots_(std::move(slots)) {
  HAPVOX_CHECK(slots_ != nullptr);
  HAPVOX_CHECK_GT(materials_.size(), 0u);
  HAPVOX_CHECK_EQ(slots_->background(), 0);
  for (const TissueMaterial& m : materials_) {
    const std::string source = m.name.empty() ? "tissue" : "tissue '" + m.name + "'";
    validate_material(m.elastic, source, source);
    const LameParameters lame = lame_parameters(m.elastic);
    if (!(std::isfinite(m.yield_stress_pa) && m.yield_stress_pa > 0.0)) {
      std::ostringstream out;
      out << "yield stress must be positive and finite, got " << m.yield_stress_pa << " Pa";
      throw InputError(source, out.str());
    }
    rows_.push_back({lame.lambda_pa, lame.mu_pa, m.elastic.youngs_modulus_pa,
                     m.elastic.poisson_ratio, m.yield_stress_pa});
  }
  const auto count = static_cast<std::int32_t>(materials_.size());
  for (auto it = slots_->cbeginValueOn(); it; ++it) {
    HAPVOX_CHECK_GE(*it, 0);
    HAPVOX_CHECK_LT(*it, count);
  }
}

int TissueMap::slot_at(const openvdb::Coord& ijk) const { return slots_->tree().getValue(ijk); }

double TissueMap::min_youngs_modulus_pa() const {
  double e = rows_.front().youngs_modulus_pa;
  for (const Row& row : rows_) e = std::min(e, row.youngs_modulus_pa);
  return e;
}

}  // namespace hapvox::engine
