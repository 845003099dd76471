#include "engine/proxy/proxy_mesh.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>

#include "../labels/input_error.h"
#include "engine/proxy/label_source.h"
#include "phantom_inputs.h"

namespace hapvox::engine::proxy {
namespace {

using testing::input_error_of;

// The four-spheres phantom at 64^3, labelled by data/four_spheres.toml's intensity ranges.
struct Phantom : testing::PhantomInputs {
  Phantom() : PhantomInputs(64) {}
  labels::LabelMap map = proxy_labels(intensity, materials, {});

  // Spacing r at the lattice, r / 4 at the spheres' surfaces (as the mesher's own tests).
  ProxyMeshOptions options() const {
    ProxyMeshOptions o;
    o.coarse_spacing_mm = spheres.radius() * spheres.voxel_mm;
    o.boundary_levels = 2;
    return o;
  }
  ProxyMesh build() const { return build_proxy_mesh(map, materials, options()); }
};

const Phantom& phantom() {
  static const Phantom p;
  return p;
}
const ProxyMesh& phantom_mesh() {
  static const ProxyMesh mesh = phantom().build();
  return mesh;
}

// The mesh follows the voxels' staircase with edges of r / 4 (2.9 mm against 1 mm voxels), so
// it cuts the stairs' corners: about -2.4 % per sphere at 64^3 (-3.4 % at 32^3).
TEST(ProxyMesh, EachSphereKeepsItsVoxelVolumeWithinThreePercent) {
  const ProxyMesh& proxy = phantom_mesh();
  const fem::ConformingMeshReport& report = proxy.report;
  std::printf("%d vertices, %d tets, dihedral %.1f-%.1f deg, %.3f s\n", report.vertex_count,
              report.tet_count, report.quality.min_dihedral_deg, report.quality.max_dihedral_deg,
              report.build_seconds);
  const auto counts = phantom().map.voxel_counts();
  for (int label = 1; label <= 4; ++label) {
    const double voxels_mm3 = static_cast<double>(counts.at(label));  // 1 mm voxels
    const double error = report.relative_volume_error_by_label.at(label);
    std::printf("  label %d: %.1f mm^3 meshed, %.0f voxels, %+.2f %%\n", label,
                report.volume_mm3_by_label.at(label), voxels_mm3, 100 * error);
    EXPECT_LT(std::abs(error), 0.03) << "label " << label;
    EXPECT_NEAR(report.volume_mm3_by_label.at(label) / voxels_mm3, 1.0, 0.03) << "label " << label;
  }
  // The background's reference is its cells clipped to the voxel-centre box, so the whole
  // mesh matches the box.
  EXPECT_LT(std::abs(report.relative_volume_error_by_label.at(0)), 0.03);
  EXPECT_NEAR(report.quality.total_volume_mm3, voxel_centre_box(phantom().map).volume(), 1e-6);
  EXPECT_EQ(report.quality.inverted_tets, 0);
  EXPECT_GE(report.quality.min_dihedral_deg, fem::kConformingMinDihedralDeg);
  EXPECT_LE(report.quality.max_dihedral_deg, fem::kConformingMaxDihedralDeg);
  EXPECT_EQ(proxy.materials_source, phantom().materials.source);
}

TEST(ProxyMesh, EveryTetHasItsLabelsMaterial) {
  const ProxyMesh& proxy = phantom_mesh();
  ASSERT_EQ(proxy.materials.size(), proxy.mesh.tets.size());
  std::set<std::int32_t> seen;
  for (int t = 0; t < proxy.mesh.tet_count(); ++t) {
    const labels::Material* m = phantom().materials.find(proxy.mesh.labels[t]);
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(proxy.materials[t].youngs_pa, m->elastic.youngs_modulus_pa) << "tet " << t;
    EXPECT_EQ(proxy.materials[t].poisson, m->elastic.poisson_ratio) << "tet " << t;
    seen.insert(proxy.mesh.labels[t]);
  }
  EXPECT_EQ(seen, (std::set<std::int32_t>{0, 1, 2, 3, 4}));
}

TEST(ProxyMesh, TheWhiteSpheresLeftQuarterIsFixedAndNothingElse) {
  const ProxyMesh& proxy = phantom_mesh();
  const auto boxes = labels::resolve_fixed_regions(phantom().materials, phantom().map);
  ASSERT_EQ(boxes.size(), 1u);
  const labels::FixedBox& box = boxes[0];
  ASSERT_EQ(box.label, 4);
  std::vector<bool> white(proxy.mesh.vertex_count(), false);
  for (int t = 0; t < proxy.mesh.tet_count(); ++t) {
    if (proxy.mesh.labels[t] != 4) continue;
    for (std::int32_t v : proxy.mesh.tets[t]) white[v] = true;
  }
  int fixed = 0;
  int background_in_box = 0;
  for (int v = 0; v < proxy.mesh.vertex_count(); ++v) {
    const Vec3d p = proxy.mesh.rest_mm.col(v);
    const bool in_box =
        (p.array() >= box.min_mm.array()).all() && (p.array() <= box.max_mm.array()).all();
    const fem::VertexClass expected =
        in_box && white[v] ? fem::VertexClass::kFixed : fem::VertexClass::kFree;
    EXPECT_EQ(proxy.vertex_classes[v], expected) << "vertex " << v;
    fixed += expected == fem::VertexClass::kFixed ? 1 : 0;
    background_in_box += in_box && !white[v] ? 1 : 0;
  }
  EXPECT_GT(fixed, 10);
  EXPECT_EQ(fixed_vertex_count(proxy), fixed);
  // The box reaches into the background around the sphere; that stays free.
  EXPECT_GT(background_in_box, 0);
}

TEST(ProxyMesh, FixedDofsAreThreePerFixedVertexInOrder) {
  const ProxyMesh& proxy = phantom_mesh();
  const std::vector<int> dofs = fixed_dofs(proxy);
  std::vector<int> expected;
  for (int v = 0; v < proxy.mesh.vertex_count(); ++v) {
    if (proxy.vertex_classes[v] != fem::VertexClass::kFixed) continue;
    expected.insert(expected.end(), {3 * v, 3 * v + 1, 3 * v + 2});
  }
  EXPECT_EQ(dofs, expected);
  EXPECT_EQ(dofs.size(), 3u * fixed_vertex_count(proxy));
}

template <typename T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

TEST(ProxyMesh, IdenticalInputsGiveAByteIdenticalMesh) {
  const ProxyMesh& a = phantom_mesh();
  const ProxyMesh b = phantom().build();
  ASSERT_EQ(a.mesh.rest_mm.cols(), b.mesh.rest_mm.cols());
  EXPECT_EQ(std::memcmp(a.mesh.rest_mm.data(), b.mesh.rest_mm.data(),
                        sizeof(double) * a.mesh.rest_mm.size()),
            0);
  EXPECT_TRUE(same_bytes(a.mesh.tets, b.mesh.tets));
  EXPECT_TRUE(same_bytes(a.mesh.labels, b.mesh.labels));
  EXPECT_TRUE(same_bytes(a.materials, b.materials));
  EXPECT_TRUE(same_bytes(a.vertex_classes, b.vertex_classes));
}

constexpr const char* kSphereMaterials = R"(
[[material]]
label = 0
youngs_modulus_pa = 10e6
poisson_ratio = 0.45
[[material]]
label = 1
youngs_modulus_pa = 0.1e6
poisson_ratio = 0.45
fixed = true
[[material]]
label = 2
youngs_modulus_pa = 100e6
poisson_ratio = 0.45
[[material]]
label = 4
youngs_modulus_pa = 1e6
poisson_ratio = 0.45
)";

TEST(ProxyMesh, ALabelWithoutMaterialIsAnInputErrorNamingTheFile) {
  const labels::Materials m = labels::parse_materials(kSphereMaterials, "spheres.toml");
  const std::int64_t red = phantom().map.voxel_counts().at(3);
  EXPECT_EQ(input_error_of([&] { build_proxy_mesh(phantom().map, m, phantom().options()); }),
            "spheres.toml: label 3 has no material (" + std::to_string(red) + " voxels)");
}

TEST(ProxyMesh, FixedMaterialsAndUnlabelledBoxesFixEveryVertexTheyHold) {
  // Blue (label 1) fixed as a material; a box without a label over the low-z corner.
  const labels::Materials m = labels::parse_materials(
      std::string(kSphereMaterials) +
          "[[material]]\nlabel = 3\nyoungs_modulus_pa = 1e7\npoisson_ratio = 0.45\n"
          "[[fixed_region]]\nmin_mm = [-1, -1, -1]\nmax_mm = [8, 8, 4]\n",
      "fixed.toml");
  const ProxyMesh proxy = build_proxy_mesh(phantom().map, m, phantom().options());
  std::vector<bool> blue(proxy.mesh.vertex_count(), false);
  for (int t = 0; t < proxy.mesh.tet_count(); ++t) {
    if (proxy.mesh.labels[t] != 1) continue;
    for (std::int32_t v : proxy.mesh.tets[t]) blue[v] = true;
  }
  int in_box = 0;
  for (int v = 0; v < proxy.mesh.vertex_count(); ++v) {
    const Vec3d p = proxy.mesh.rest_mm.col(v);
    const bool boxed = p.x() <= 8 && p.y() <= 8 && p.z() <= 4;
    in_box += boxed ? 1 : 0;
    EXPECT_EQ(proxy.vertex_classes[v] == fem::VertexClass::kFixed, blue[v] || boxed)
        << "vertex " << v;
  }
  EXPECT_GT(in_box, 0);
}

TEST(ProxyMesh, DefaultSpacingIsAnEighthOfTheShortestSide) {
  // One label: no boundary to refine at, so the lattice is the plain one.
  const labels::LabelMap uniform(Vec3i(16, 20, 24), Vec3d::Ones(), Vec3d::Zero());
  const labels::Materials one = labels::parse_materials(
      "[[material]]\nlabel = 0\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.3\n", "one.toml");
  const ProxyMesh proxy = build_proxy_mesh(uniform, one);
  // 15 mm / 8 = 1.875 mm: 8, 10 and 12 cells along x, y and z.
  EXPECT_EQ(proxy.report.lattice_vertex_count, 9 * 11 * 13);
  EXPECT_EQ(proxy.report.lattice_tet_count, 6 * 8 * 10 * 12);
  EXPECT_EQ(fixed_vertex_count(proxy), 0);
}

TEST(ProxyMesh, BadOptionsAreInputErrors) {
  ProxyMeshOptions options = phantom().options();
  options.boundary_levels = -1;
  EXPECT_NE(input_error_of([&] {
              build_proxy_mesh(phantom().map, phantom().materials, options);
            }).find("proxy mesh: "),
            std::string::npos);
}

}  // namespace
}  // namespace hapvox::engine::proxy
