// Materials by tissue in the voxel model (engine/tissue_map.h, ToolForceModel with a
// TissueMap): the elastic stress takes the material at each quadrature point.
#include "engine/tissue_map.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "engine/block_field.h"
#include "engine/errors.h"
#include "engine/tool_force.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using fixtures::make_block;
using ::hapvox::testing::input_error_of;

constexpr int kN = 48;     // 48 mm block, 1 mm voxels
constexpr int kTopK = 24;  // nominal surface z = 23.5 mm
constexpr double kSurfaceZ = 23.5;
constexpr double kSoftPa = 100e3;     // left half, x < 24 mm
constexpr double kHardPa = 400e3;     // right half, x >= 24 mm
constexpr double kFallbackPa = 1e12;  // row 0: the empty voxels above the block

// The block's left half is row 1 (soft), its right half row 2 (hard, or `right`); the empty
// voxels keep slot 0, a far stiffer fallback that must not be felt.
TissueMap slab_tissue(const TissueMaterial& right) {
  auto slots = openvdb::Int32Grid::create(0);
  auto accessor = slots->getAccessor();
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j)
      for (int k = 0; k < kTopK; ++k) accessor.setValue({i, j, k}, i < kN / 2 ? 1 : 2);
  return TissueMap({{"fallback", {kFallbackPa, 0.3}, 1e9}, {"soft", {kSoftPa, 0.3}, 10e3}, right},
                   slots);
}

TissueMaterial hard() { return {"hard", {kHardPa, 0.3}, 20e3}; }

ToolForceOptions elastic_tool() {
  ToolForceOptions o;  // Hertz law, 8 mm tool
  o.material = {kFallbackPa, 0.3};
  return o;
}

// The force after a press from 1 mm above the surface to `depth_mm` at (x, y).
Vec3d press(const ToolForceModel& model, double x_mm, double depth_mm, double y_mm = 24.2) {
  ToolForceState state = model.make_state();
  const double r = model.tool_radius_mm();
  for (double d = -1.0; d <= depth_mm + 1e-9; d += 0.05) {
    model.step(Vec3d(x_mm, y_mm, kSurfaceZ + r - d), state);
  }
  return state.force_n;
}

TEST(TissueForce, TheTwoMaterialSlabsForceRatioIsTheRatioOfItsModuli) {
  const DensityField field = make_block(kN, kTopK, Vec3d::Ones());
  const TissueMap tissue = slab_tissue(hard());
  const ToolForceModel model(field, elastic_tool(), &tissue);
  for (double depth : {0.5, 1.0, 1.5}) {
    // 12 mm from the interface on each side: the same contact, shifted by 24 voxels.
    const Vec3d soft = press(model, 11.7, depth);
    const Vec3d stiff = press(model, 35.7, depth);
    ASSERT_GT(soft.z(), 0.01) << depth;
    EXPECT_NEAR(stiff.z() / soft.z(), kHardPa / kSoftPa, 1e-5) << depth;
    EXPECT_NEAR(stiff.x() / stiff.z(), soft.x() / soft.z(), 1e-6) << depth;
    // Each side is exactly the one-material model of its own material.
    ToolForceOptions uniform = elastic_tool();
    uniform.material.youngs_modulus_pa = kSoftPa;
    const ToolForceModel soft_only(field, uniform);
    const Vec3d expected = press(soft_only, 11.7, depth);
    EXPECT_LT((soft - expected).norm(), 1e-9 * expected.norm()) << depth;
  }
}

TEST(TissueForce, PoissonsRatioIsEachTissuesOwn) {
  // Right half: same E, nu = 0.45. Under the Hertz law F = 4/3 E/(1 - nu^2) sqrt(R) d^1.5,
  // so the ratio is (1 - 0.3^2) / (1 - 0.45^2), and each side matches its uniform model.
  const DensityField field = make_block(kN, kTopK, Vec3d::Ones());
  const TissueMap tissue = slab_tissue({"incompressible", {kSoftPa, 0.45}, 20e3});
  const ToolForceModel model(field, elastic_tool(), &tissue);
  const Vec3d left = press(model, 11.7, 1.0);
  const Vec3d right = press(model, 35.7, 1.0);
  EXPECT_NEAR(right.z() / left.z(), (1 - 0.09) / (1 - 0.2025), 1e-5);
  ToolForceOptions uniform = elastic_tool();
  uniform.material = {kSoftPa, 0.45};
  const ToolForceModel right_only(field, uniform);
  const Vec3d expected = press(right_only, 35.7, 1.0);
  EXPECT_LT((right - expected).norm(), 1e-9 * expected.norm());
}

TEST(TissueForce, ATouchOnTheInterfaceFeelsBothAreaWeighted) {
  const DensityField field = make_block(kN, kTopK, Vec3d::Ones());
  const TissueMap tissue = slab_tissue(hard());
  const ToolForceModel model(field, elastic_tool(), &tissue);
  const double soft = press(model, 11.7, 1.0).z();
  const double stiff = press(model, 35.7, 1.0).z();
  // Centred on the interface (voxel faces at x = 23.5): half the contact on each side.
  const Vec3d mid = press(model, 23.5, 1.0);
  EXPECT_GT(mid.z(), soft);
  EXPECT_LT(mid.z(), stiff);
  EXPECT_NEAR(mid.z(), 0.5 * (soft + stiff), 0.03 * (soft + stiff));
  ToolForceState state = model.make_state();
  model.step(Vec3d(23.5, 24.2, kSurfaceZ + 4.0 - 1.0), state);
  EXPECT_NEAR(model.contact_youngs_modulus_pa(state.contact), 0.5 * (kSoftPa + kHardPa),
              0.03 * kHardPa);
}

TEST(TissueForce, EachTissueYieldsAtItsOwnStress) {
  const DensityField field = make_block(kN, kTopK, Vec3d::Ones());
  // Soft: sigma_f 10 kPa; hard: 4x stiffer and sigma_f 10 MPa. Pressed 1.5 mm, the soft
  // side's mean contact pressure (17 kPa elastic) passes its yield, the hard side's (68 kPa)
  // stays far below its own.
  const TissueMap tissue = slab_tissue({"bone", {kHardPa, 0.3}, 10e6});
  ToolForceOptions options = elastic_tool();
  options.plastic.enabled = true;
  const ToolForceModel model(field, options, &tissue);
  for (const auto& [x_mm, should_yield] : {std::pair{11.7, true}, std::pair{35.7, false}}) {
    ToolForceState state = model.make_state();
    for (double d = -1.0; d <= 1.5; d += 0.05) {
      model.step(Vec3d(x_mm, 24.2, kSurfaceZ + 4.0 - d), state);
    }
    EXPECT_EQ(state.plastic_steps > 0, should_yield) << x_mm << " mm: " << state.plastic_steps;
    // sigma_f is the contact's own tissue's (no hardening: E_ep = 0).
    const double yield_pa = should_yield ? 10e3 : 10e6;
    EXPECT_NEAR(state.yield_stress_pa, yield_pa, 1e-9 * yield_pa) << x_mm;
  }
}

TEST(TissueForce, PlasticityNeedsEveryTissueStifferThanItsHardeningSlope) {
  const DensityField field = make_block(16, 8, Vec3d::Ones());
  const TissueMap tissue = slab_tissue(hard());
  ToolForceOptions options = elastic_tool();
  options.plastic.enabled = true;
  options.plastic.elastoplastic_modulus_pa = 200e3;  // below E of row 0 and 2, above row 1's
  EXPECT_EQ(input_error_of([&] { ToolForceModel(field, options, &tissue); }),
            "material: elasto-plastic modulus must lie in [0, E), got 200000 Pa (the softest "
            "material's E is 100000 Pa)");
}

TEST(TissueMapTable, NamesTheTissueWithABadMaterial) {
  auto slots = openvdb::Int32Grid::create(0);
  EXPECT_EQ(input_error_of([&] {
              TissueMap({{"fat", {-1.0, 0.3}, 1e3}}, slots);
            }),
            "tissue 'fat': Young's modulus must be positive and finite, got -1 Pa");
  EXPECT_EQ(input_error_of([&] {
              TissueMap({{"", {1e5, 0.3}, 0.0}}, slots);
            }),
            "tissue: yield stress must be positive and finite, got 0 Pa");
  const TissueMap ok({{"a", {1e5, 0.25}, 1e3}, {"b", {2e5, 0.3}, 2e3}}, slots);
  ASSERT_EQ(ok.rows().size(), 2u);
  EXPECT_DOUBLE_EQ(ok.rows()[1].mu_pa, 2e5 / 2.6);
  EXPECT_DOUBLE_EQ(ok.rows()[0].lambda_pa, 1e5 * 0.25 / (1.25 * 0.5));
  EXPECT_EQ(ok.min_youngs_modulus_pa(), 1e5);
  EXPECT_EQ(ok.slot_at({3, 4, 5}), 0);
}

}  // namespace
}  // namespace hapvox::engine
