#include "engine/fem/conforming_mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>

#include "engine/errors.h"
#include "fem_fixtures.h"

namespace hapvox::engine::fem {
namespace {

// Four spheres (labels 1-4) in a background (label 0), off the lattice's grid.
struct FourSpheres {
  double radius_mm = 8.0;
  Eigen::AlignedBox3d box{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(64, 64, 32)};
  std::array<Eigen::Vector3d, 4> centers = {
      Eigen::Vector3d(16.3, 15.7, 16.2), Eigen::Vector3d(45.1, 16.6, 15.4),
      Eigen::Vector3d(15.2, 47.9, 16.9), Eigen::Vector3d(47.7, 44.8, 15.8)};

  LabelFunction label() const {
    return [*this](const Eigen::Vector3d& x) -> std::int32_t {
      for (int s = 0; s < 4; ++s) {
        if ((x - centers[s]).squaredNorm() < radius_mm * radius_mm) return s + 1;
      }
      return 0;
    };
  }
  std::map<std::int32_t, double> reference_volumes() const {
    const double sphere = 4.0 / 3.0 * std::numbers::pi * std::pow(radius_mm, 3);
    return {{1, sphere}, {2, sphere}, {3, sphere}, {4, sphere}, {0, box.volume() - 4 * sphere}};
  }
  // Spacing r at the lattice, r / 4 at the spheres' surfaces.
  ConformingMeshOptions options() const {
    ConformingMeshOptions options;
    options.box_mm = box;
    options.coarse_spacing_mm = radius_mm;
    options.boundary_levels = 2;
    return options;
  }
  ConformingMesh build(const ConformingMeshOptions& options) const {
    return build_conforming_mesh(options, label(), reference_volumes());
  }
};

void print(const char* what, const ConformingMeshReport& report) {
  std::printf(
      "%s: %d vertices, %d tets (lattice %d / %d), %d warped, %d refused, %d cut points, %d cut "
      "tets, dihedral %.2f-%.2f deg, %.3f s\n",
      what, report.vertex_count, report.tet_count, report.lattice_vertex_count,
      report.lattice_tet_count, report.warped_vertices, report.refused_warps, report.cut_points,
      report.cut_tets, report.quality.min_dihedral_deg, report.quality.max_dihedral_deg,
      report.build_seconds);
  for (const auto& [label, error] : report.relative_volume_error_by_label) {
    std::printf("  label %d: volume %.3f mm^3, error %+.3f %%\n", label,
                report.volume_mm3_by_label.at(label), 100 * error);
  }
}

// The faces between tets of different labels, as sorted vertex triples.
std::vector<std::array<std::int32_t, 3>> interface_faces(const TetMesh& mesh) {
  struct Face {
    std::array<std::int32_t, 3> key;
    std::int32_t label;
  };
  std::vector<Face> faces;
  for (int t = 0; t < mesh.tet_count(); ++t) {
    for (int skip = 0; skip < 4; ++skip) {
      Face face{{}, mesh.labels[t]};
      for (int k = 0, n = 0; k < 4; ++k) {
        if (k != skip) face.key[n++] = mesh.tets[t][k];
      }
      std::sort(face.key.begin(), face.key.end());
      faces.push_back(face);
    }
  }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  std::vector<std::array<std::int32_t, 3>> out;
  for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
    if (faces[i].key == faces[i + 1].key && faces[i].label != faces[i + 1].label) {
      out.push_back(faces[i].key);
    }
  }
  return out;
}

TEST(ConformingMesh, FourSpheresHasTheDocumentedQualityAndVolumes) {
  const FourSpheres phantom;
  const ConformingMesh built = phantom.build(phantom.options());
  const ConformingMeshReport& report = built.report;
  print("four spheres", report);
  EXPECT_NO_THROW(validate(built.mesh, "four spheres"));
  EXPECT_EQ(report.quality.inverted_tets, 0);
  EXPECT_EQ(report.dropped_degenerate_tets, 0);
  EXPECT_EQ(report.unresolved_tets, 0);
  EXPECT_GT(report.cut_tets, 0);
  EXPECT_GT(report.warped_vertices, 0);
  EXPECT_GE(report.quality.min_dihedral_deg, kConformingMinDihedralDeg);
  EXPECT_LE(report.quality.max_dihedral_deg, kConformingMaxDihedralDeg);
  // Checked tet by tet too, not only through the report.
  for (const Tet& tet : built.mesh.tets) {
    const auto x = [&](int k) -> Eigen::Vector3d { return built.mesh.rest_mm.col(tet[k]); };
    ASSERT_GT(signed_volume_mm3(x(0), x(1), x(2), x(3)), 0);
    for (double angle : dihedral_angles_deg(x(0), x(1), x(2), x(3))) {
      ASSERT_GE(angle, kConformingMinDihedralDeg);
      ASSERT_LE(angle, kConformingMaxDihedralDeg);
    }
  }
  fixtures::expect_conforming_box(built.mesh, phantom.box.min(), phantom.box.max());
  EXPECT_NEAR(report.quality.total_volume_mm3 / phantom.box.volume(), 1.0, 1e-9);
  for (int s = 1; s <= 4; ++s) {
    EXPECT_LT(std::abs(report.relative_volume_error_by_label.at(s)), 0.03) << "sphere " << s;
  }
}

TEST(ConformingMesh, EveryTetHasTheLabelAtItsCentroid) {
  const FourSpheres phantom;
  const ConformingMesh built = phantom.build(phantom.options());
  const LabelFunction label = phantom.label();
  std::array<int, 5> tets_per_label{};
  for (int t = 0; t < built.mesh.tet_count(); ++t) {
    const Tet& tet = built.mesh.tets[t];
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (std::int32_t v : tet) centroid += 0.25 * built.mesh.rest_mm.col(v);
    ASSERT_EQ(built.mesh.labels[t], label(centroid)) << "tet " << t;
    ++tets_per_label.at(built.mesh.labels[t]);
  }
  for (int count : tets_per_label) EXPECT_GT(count, 0);
  EXPECT_EQ(built.report.centroid_label_mismatches, 0);
  // Few tets needed their centroid to decide: the cut had put nearly all on the right side.
  EXPECT_LT(built.report.relabelled_tets, built.report.cut_tets / 20);
}

TEST(ConformingMesh, LabelInterfacesLieOnTheSpheres) {
  // Conforming: the faces between labels are made of vertices on the spheres (cut points and
  // warped vertices), except the far vertex of a relabelled tet, within a fraction of the
  // boundary spacing (r / 4) of them.
  const FourSpheres phantom;
  const ConformingMesh built = phantom.build(phantom.options());
  const double spacing = phantom.radius_mm / 4;
  int on = 0, off = 0;
  double farthest = 0;
  for (const auto& face : interface_faces(built.mesh)) {
    for (std::int32_t v : face) {
      double distance = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector3d& center : phantom.centers) {
        distance = std::min(
            distance, std::abs((built.mesh.rest_mm.col(v) - center).norm() - phantom.radius_mm));
      }
      farthest = std::max(farthest, distance);
      (distance < 1e-9 * phantom.radius_mm ? on : off) += 1;
    }
  }
  std::printf("interface vertex visits: %d on a sphere, %d off (farthest %.3f mm)\n", on, off,
              farthest);
  EXPECT_GT(on, 1000);
  EXPECT_LT(off, on / 50);
  EXPECT_LT(farthest, 0.25 * spacing);
}

TEST(ConformingMesh, IsBitIdenticalOnTwoRuns) {
  const FourSpheres phantom;
  ConformingMeshOptions options = phantom.options();
  options.tool_region = Sphere{Eigen::Vector3d(30, 30, 16), 6.0};
  const TetMesh a = phantom.build(options).mesh, b = phantom.build(options).mesh;
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  ASSERT_EQ(a.tet_count(), b.tet_count());
  EXPECT_EQ(std::memcmp(a.rest_mm.data(), b.rest_mm.data(), sizeof(double) * a.rest_mm.size()), 0);
  EXPECT_EQ(std::memcmp(a.tets.data(), b.tets.data(), sizeof(Tet) * a.tets.size()), 0);
  EXPECT_EQ(a.labels, b.labels);
}

int vertices_in(const TetMesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& where) {
  return static_cast<int>(fixtures::vertices_where(mesh, where).size());
}

TEST(ConformingMesh, ToolRegionRaisesTheVertexDensityThereOnly) {
  const FourSpheres phantom;
  ConformingMeshOptions options = phantom.options();
  const TetMesh plain = phantom.build(options).mesh;
  const Sphere tool{Eigen::Vector3d(31, 30, 15), 5.0};
  options.tool_region = tool;
  options.tool_levels = 2;
  const ConformingMesh refined = phantom.build(options);
  auto distance = [&](const Eigen::Vector3d& x) { return (x - tool.center_mm).norm(); };
  auto inside = [&](const Eigen::Vector3d& x) { return distance(x) <= tool.radius_mm; };
  // Far: beyond two coarse cells from the tool region.
  auto far = [&](const Eigen::Vector3d& x) {
    return distance(x) > tool.radius_mm + 2 * std::sqrt(3.0) * options.coarse_spacing_mm;
  };
  const int plain_inside = vertices_in(plain, inside),
            refined_inside = vertices_in(refined.mesh, inside);
  std::printf("tool sphere: %d vertices inside without, %d with refinement; %d / %d far\n",
              plain_inside, refined_inside, vertices_in(plain, far),
              vertices_in(refined.mesh, far));
  // Two halvings of the spacing: about 4^3 times the density, at least half of a full lattice
  // of spacing h / 4 in the sphere.
  const double fine = options.coarse_spacing_mm / 4;
  EXPECT_GT(refined_inside, 8 * std::max(plain_inside, 1));
  EXPECT_GT(refined_inside,
            0.5 * (4.0 / 3.0 * std::numbers::pi * std::pow(tool.radius_mm, 3)) / std::pow(fine, 3));
  EXPECT_EQ(vertices_in(refined.mesh, far), vertices_in(plain, far));
  EXPECT_GE(refined.report.quality.min_dihedral_deg, kConformingMinDihedralDeg);
  EXPECT_LE(refined.report.quality.max_dihedral_deg, kConformingMaxDihedralDeg);
  fixtures::expect_conforming_box(refined.mesh, phantom.box.min(), phantom.box.max());
}

TEST(ConformingMesh, DocumentedDihedralRangeHoldsOnRandomSpheres) {
  // Three spheres of one random radius at random places (apart from each other), repeatedly.
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0, 1);
  double lowest = 180, highest = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const double r = 5 + 7 * unit(random);
    std::vector<Eigen::Vector3d> centers;
    while (centers.size() < 3) {
      const Eigen::Vector3d x(12 + 40 * unit(random), 12 + 40 * unit(random),
                              10 + 12 * unit(random));
      bool apart = true;
      for (const Eigen::Vector3d& y : centers) apart = apart && (x - y).norm() > 2 * r + 3;
      if (apart) centers.push_back(x);
    }
    const LabelFunction label = [&](const Eigen::Vector3d& x) -> std::int32_t {
      for (int s = 0; s < 3; ++s) {
        if ((x - centers[s]).squaredNorm() < r * r) return s + 1;
      }
      return 0;
    };
    ConformingMeshOptions options;
    options.box_mm = Eigen::AlignedBox3d(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(64, 64, 32));
    options.coarse_spacing_mm = r;
    const ConformingMeshReport report = build_conforming_mesh(options, label).report;
    EXPECT_EQ(report.quality.inverted_tets, 0);
    EXPECT_EQ(report.dropped_degenerate_tets, 0);
    EXPECT_EQ(report.unresolved_tets, 0);
    EXPECT_NEAR(report.quality.total_volume_mm3 / options.box_mm.volume(), 1.0, 1e-9);
    lowest = std::min(lowest, report.quality.min_dihedral_deg);
    highest = std::max(highest, report.quality.max_dihedral_deg);
  }
  std::printf("random spheres: dihedral %.2f-%.2f deg\n", lowest, highest);
  EXPECT_GE(lowest, kConformingMinDihedralDeg);
  EXPECT_LE(highest, kConformingMaxDihedralDeg);
}

TEST(ConformingMesh, WarpingIsWhatKeepsSliversOut) {
  // Without warping, cut points next to vertices make slivers: the guard is doing work.
  const FourSpheres phantom;
  ConformingMeshOptions options = phantom.options();
  options.warp_fraction = 0;
  const ConformingMeshReport report = phantom.build(options).report;
  EXPECT_EQ(report.warped_vertices, 0);
  EXPECT_LT(report.quality.min_dihedral_deg, kConformingMinDihedralDeg);
}

TEST(ConformingMesh, ClassifiesFixedAndFreeVertices) {
  const FourSpheres phantom;
  const TetMesh mesh = phantom.build(phantom.options()).mesh;
  const Eigen::AlignedBox3d left_face(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(0, 65, 33));
  const std::vector<VertexClass> classes = classify_vertices(mesh, {2}, {left_face});
  ASSERT_EQ(static_cast<int>(classes.size()), mesh.vertex_count());
  std::vector<char> in_label_2(mesh.vertex_count(), 0);
  for (int t = 0; t < mesh.tet_count(); ++t) {
    if (mesh.labels[t] == 2) {
      for (std::int32_t v : mesh.tets[t]) in_label_2[v] = 1;
    }
  }
  int fixed = 0;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const bool expected = in_label_2[v] || mesh.rest_mm(0, v) <= 0.0;
    EXPECT_EQ(classes[v], expected ? VertexClass::kFixed : VertexClass::kFree) << "vertex " << v;
    fixed += classes[v] == VertexClass::kFixed;
  }
  EXPECT_GT(fixed, 0);
  EXPECT_LT(fixed, mesh.vertex_count() / 2);
}

TEST(ConformingMesh, RejectsBadOptions) {
  const FourSpheres phantom;
  const auto bad = [&](auto change) {
    ConformingMeshOptions options = phantom.options();
    change(options);
    EXPECT_THROW(phantom.build(options), InputError);
  };
  bad([](ConformingMeshOptions& o) { o.coarse_spacing_mm = 0; });
  bad([](ConformingMeshOptions& o) { o.box_mm = Eigen::AlignedBox3d(); });
  bad([](ConformingMeshOptions& o) { o.boundary_levels = -1; });
  bad([](ConformingMeshOptions& o) { o.warp_fraction = 0.6; });
  bad([](ConformingMeshOptions& o) { o.tool_region = Sphere{Eigen::Vector3d::Zero(), 0.0}; });
}

}  // namespace
}  // namespace hapvox::engine::fem
