#include "engine/labels/label_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "engine/errors.h"
#include "engine/volume_io.h"
#include "four_spheres.h"
#include "test_data.h"

namespace hapvox::engine::labels {
namespace {

using ::hapvox::testing::FourSpheres;
using ::hapvox::testing::input_error_of;
using ::hapvox::testing::scratch_dir;

std::vector<Seed> sphere_seeds(const FourSpheres& phantom) {
  std::vector<Seed> seeds;
  for (int s = 0; s < 4; ++s) seeds.push_back(Seed{phantom.centre_mm(s), s + 1});
  return seeds;
}

/// A small hand-made volume: `dims` voxels of spacing 1 at the origin, zero but for `values`.
DensityField small_field(const Vec3i& dims, const std::vector<std::pair<Vec3i, float>>& values) {
  initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  for (const auto& [ijk, v] : values) {
    grid->tree().setValue(openvdb::Coord(ijk.x(), ijk.y(), ijk.z()), v);
  }
  return DensityField(grid, Vec3d::Ones(), Vec3d::Zero(), dims);
}

// ---- geometry and boundaries ----------------------------------------------------------

TEST(LabelMap, WorldPointsFallInTheirVoxelsCellAndNowhereOutside) {
  LabelMap map(Vec3i(4, 3, 2), Vec3d(0.5, 1.0, 2.0), Vec3d(10.0, 20.0, 30.0));
  map.set(Vec3i(3, 2, 1), 7);
  // Voxel (3, 2, 1) is centred at (11.5, 22, 32); its cell reaches half a voxel either way.
  EXPECT_EQ(map.voxel_at_world(Vec3d(11.5, 22.0, 32.0)), Vec3i(3, 2, 1));
  EXPECT_EQ(map.voxel_at_world(Vec3d(11.74, 22.49, 32.99)), Vec3i(3, 2, 1));
  EXPECT_EQ(map.voxel_at_world(Vec3d(11.26, 21.51, 31.01)), Vec3i(3, 2, 1));
  EXPECT_EQ(map.voxel_at_world(Vec3d(9.76, 19.51, 29.01)), Vec3i(0, 0, 0));
  EXPECT_FALSE(map.voxel_at_world(Vec3d(11.76, 22.0, 32.0)));
  EXPECT_FALSE(map.voxel_at_world(Vec3d(9.74, 20.0, 30.0)));
  EXPECT_FALSE(map.voxel_at_world(Vec3d(10.0, 20.0, 33.01)));
  EXPECT_FALSE(map.voxel_at_world(Vec3d(NAN, 20.0, 30.0)));
  EXPECT_EQ(map.at_world(Vec3d(11.6, 22.2, 32.5)), 7);
  EXPECT_EQ(map.at_world(Vec3d(11.2, 22.2, 32.5)), 0);
  EXPECT_EQ(map.at_world(Vec3d(100.0, 22.2, 32.5)), 0);
}

TEST(LabelMap, BoundaryIsWhereASixNeighbourHoldsAnotherLabel) {
  LabelMap map(Vec3i(3, 3, 3), Vec3d::Ones(), Vec3d::Zero());
  map.set(Vec3i(1, 1, 1), 5);
  EXPECT_TRUE(map.is_boundary(Vec3i(1, 1, 1)));
  EXPECT_TRUE(map.is_boundary(Vec3i(1, 1, 0)));   // a face neighbour
  EXPECT_FALSE(map.is_boundary(Vec3i(1, 0, 0)));  // an edge neighbour: not 6-connected
  EXPECT_FALSE(map.is_boundary(Vec3i(0, 0, 0)));  // the volume's own faces are no boundary
  EXPECT_EQ(map.boundary_voxels(5), std::vector<Vec3i>{Vec3i(1, 1, 1)});
  EXPECT_EQ(map.boundary_voxels(0).size(), 6u);
  const auto counts = map.voxel_counts();
  EXPECT_EQ(counts.at(0), 26);
  EXPECT_EQ(counts.at(5), 1);
  EXPECT_EQ(counts.size(), 2u);
}

// ---- region growing and intensity ranges ----------------------------------------------

TEST(RegionGrowing, RecoversEachSphereOfThePhantom) {
  const FourSpheres phantom{64, 0.5};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  ASSERT_EQ(intensity.dims, Vec3i::Constant(64));
  const LabelMap map = grow_regions(intensity, sphere_seeds(phantom), 0.05, "seeds");
  const auto counts = map.voxel_counts();
  std::int64_t in_spheres = 0;
  for (int s = 0; s < 4; ++s) {
    const std::int64_t lattice = phantom.lattice_count(s);
    const double analytic = phantom.analytic_voxels();
    EXPECT_EQ(counts.at(s + 1), lattice) << "sphere " << s;
    EXPECT_NEAR(counts.at(s + 1) / analytic, 1.0, 0.01) << "sphere " << s;
    std::printf("sphere %d (density %.1f): %lld voxels grown, 4/3 pi r^3 = %.1f (%+.3f %%)\n", s,
                FourSpheres::density(s), static_cast<long long>(counts.at(s + 1)), analytic,
                100.0 * (counts.at(s + 1) / analytic - 1.0));
    in_spheres += counts.at(s + 1);
    // Every voxel of the region is inside its sphere.
    for (int z = 0; z < 64; ++z) {
      for (int y = 0; y < 64; ++y) {
        for (int x = 0; x < 64; ++x) {
          if (map.at(Vec3i(x, y, z)) == s + 1) {
            ASSERT_TRUE(phantom.inside(s, Vec3i(x, y, z)));
          }
        }
      }
    }
  }
  EXPECT_EQ(counts.at(0), 64 * 64 * 64 - in_spheres);
}

TEST(RegionGrowing, ToleranceDecidesWhatTheRegionTakesAndEarlierSeedsKeepTheirs) {
  const FourSpheres phantom{32, 1.0};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  std::int64_t spheres[4];
  for (int s = 0; s < 4; ++s) spheres[s] = phantom.lattice_count(s);
  const std::int64_t total = 32 * 32 * 32;
  const std::int64_t background = total - spheres[0] - spheres[1] - spheres[2] - spheres[3];

  // From the 0.4 sphere with tolerance 0.45: the background (0), 0.6 and 0.8 are within it,
  // the 1.0 sphere is not.
  LabelMap map = LabelMap::like(intensity);
  EXPECT_EQ(grow_region(map, intensity, Seed{phantom.centre_mm(0), 9}, 0.45, "seeds"),
            total - spheres[3]);
  // Tolerance 0.39 from the same seed: the 0.6 and 0.8 spheres only touch the background,
  // which is out of reach, so the sphere alone.
  LabelMap narrow = LabelMap::like(intensity);
  EXPECT_EQ(grow_region(narrow, intensity, Seed{phantom.centre_mm(0), 9}, 0.39, "seeds"),
            spheres[0]);
  // A background seed first, then a sphere seed: the sphere keeps only what is left.
  LabelMap ordered = grow_regions(
      intensity,
      {Seed{Vec3d(0.0, 0.0, 0.0), 1}, Seed{phantom.centre_mm(1), 2}, Seed{Vec3d(1.0, 0.0, 0.0), 3}},
      0.05, "seeds");
  const auto counts = ordered.voxel_counts();
  EXPECT_EQ(counts.at(1), background);
  EXPECT_EQ(counts.at(2), spheres[1]);
  EXPECT_EQ(counts.count(3), 0u);  // its voxel was the first seed's already
}

RawVolume volume(const Vec3i& dims, const Vec3d& spacing, std::vector<float> values) {
  RawVolume v;
  v.dims = dims;
  v.spacing_mm = spacing;
  v.intensity = std::move(values);
  return v;
}

TEST(RegionGrowing, TakesSixNeighboursWithinTheToleranceInclusive) {
  // A row 0 1 2 3 1 from a seed at the first 1 with tolerance 1: 0, 1 and 2 are within it
  // (|I - 1| <= 1, the bound included); 3 is not, and the last 1 lies beyond it.
  const RawVolume row = volume(Vec3i(5, 1, 1), Vec3d::Ones(), {0, 1, 2, 3, 1});
  LabelMap map = LabelMap::like(row);
  EXPECT_EQ(grow_region(map, row, Seed{Vec3d(1.0, 0.0, 0.0), 4}, 1.0, "seeds"), 3);
  EXPECT_EQ(map.data(), (std::vector<Label>{4, 4, 4, 0, 0}));
  // Diagonal neighbours are not connected: of two 5s touching at a corner, one grows.
  const RawVolume plane = volume(Vec3i(3, 3, 1), Vec3d::Ones(), {5, 0, 0, 0, 5, 0, 0, 0, 0});
  LabelMap diagonal = LabelMap::like(plane);
  EXPECT_EQ(grow_region(diagonal, plane, Seed{Vec3d(0.0, 0.0, 0.0), 1}, 0.0, "seeds"), 1);
}

TEST(RegionGrowing, SeedOutsideTheVolumeIsAnInputError) {
  const RawVolume intensity = dense_intensity(generate_volume("four-spheres:dims=16"));
  EXPECT_EQ(input_error_of([&] {
              grow_regions(intensity, {Seed{Vec3d(100.0, 5.0, 5.0), 1}}, 0.1, "--seed");
            }),
            "--seed: seed (100, 5, 5) mm lies outside the volume (-0.5, -0.5, -0.5) to "
            "(15.5, 15.5, 15.5) mm");
  EXPECT_EQ(input_error_of([&] {
              grow_regions(intensity, {Seed{Vec3d(5.0, 5.0, 5.0), 1}}, -1.0, "--seed");
            }),
            "--seed: region-growing tolerance must be a finite number >= 0, got -1");
  EXPECT_EQ(input_error_of([&] {
              grow_regions(intensity, {Seed{Vec3d(5.0, 5.0, 5.0), 0}}, 0.1, "--seed");
            }),
            "--seed: seed label must lie in [1, 16777216], got 0");
}

TEST(IntensityRanges, GiveTheSameLabelsAsRegionGrowingAndFirstMatchWins) {
  const FourSpheres phantom{48, 1.0};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  const LabelMap grown = grow_regions(intensity, sphere_seeds(phantom), 0.05, "seeds");
  const LabelMap ranged = labels_from_intensity_ranges(
      intensity, {{1, 0.35, 0.45}, {2, 0.55, 0.65}, {3, 0.75, 0.85}, {4, 0.95, 1.05}});
  EXPECT_EQ(ranged.data(), grown.data());
  EXPECT_EQ(ranged.voxel_counts().size(), 5u);

  // Overlapping ranges: the first one listed takes the voxel.
  const LabelMap first = labels_from_intensity_ranges(intensity, {{7, 0.3, 0.9}, {1, 0.35, 0.45}});
  const auto counts = first.voxel_counts();
  EXPECT_EQ(counts.count(1), 0u);
  EXPECT_EQ(counts.at(7),
            phantom.lattice_count(0) + phantom.lattice_count(1) + phantom.lattice_count(2));

  // Both ends are inclusive: a range of one value takes exactly the voxels holding it.
  const double blue = FourSpheres::density(0);
  const LabelMap exact = labels_from_intensity_ranges(intensity, {{1, blue, blue}});
  EXPECT_EQ(exact.voxel_counts().at(1), phantom.lattice_count(0));
}

// ---- label volumes ----------------------------------------------------------------------

TEST(LabelVolume, RoundTripsThroughNrrdAndVdb) {
  const FourSpheres phantom{40, 0.75};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  LabelMap labels = grow_regions(intensity, sphere_seeds(phantom), 0.05, "seeds");
  const std::string dir = scratch_dir();
  // Large labels survive too: NRRD holds any up to 2^24, .vdb densities up to 1000.
  for (const auto& [file, corner] : {std::pair<std::string, Label>{"/labels.nrrd", 65535},
                                     std::pair<std::string, Label>{"/labels.vdb", 999}}) {
    labels.set(Vec3i(0, 0, 0), corner);
    if (file == "/labels.nrrd") {
      write_nrrd(label_field(labels), dir + file);
    } else {
      write_vdb(label_field(labels), dir + file);
    }
    const LabelMap back = read_label_volume(dir + file, intensity, phantom.spec());
    EXPECT_EQ(back.dims(), labels.dims()) << file;
    EXPECT_EQ(back.spacing_mm(), labels.spacing_mm()) << file;
    EXPECT_EQ(back.origin_mm(), labels.origin_mm()) << file;
    EXPECT_EQ(back.data(), labels.data()) << file;
    EXPECT_EQ(back.voxel_counts().size(), 6u) << file;
  }
}

TEST(LabelVolume, AGeneratorServesAsALabelVolume) {
  const RawVolume intensity = dense_intensity(generate_volume("block:dims=8,fill=0.25"));
  const LabelMap map =
      read_label_volume("sphere:dims=8,radius_mm=2,edge=binary", intensity, "block");
  const auto counts = map.voxel_counts();
  EXPECT_EQ(counts.size(), 2u);
  // Voxel centres within 2 of (3.5, 3.5, 3.5): offsets of +-0.5 and +-1.5 per axis with
  // squared distance <= 4: (0.5,0.5,0.5) x8, (1.5,0.5,0.5) x24.
  EXPECT_EQ(counts.at(1), 32);
}

TEST(LabelVolume, BadValuesAndMismatchedGeometryNameTheFile) {
  const std::string dir = scratch_dir();
  const RawVolume intensity = dense_intensity(small_field(Vec3i(4, 3, 2), {}));
  RawVolume coarse = intensity;
  coarse.spacing_mm = Vec3d(1.0, 1.0, 2.0);
  RawVolume shifted = intensity;
  shifted.origin_mm = Vec3d(0.0, -3.5, 0.0);
  struct Case {
    std::string file;
    DensityField labels;
    const RawVolume* intensity;
    std::string problem;
  };
  const std::vector<Case> cases = {
      {"fraction.nrrd",
       small_field(Vec3i(4, 3, 2), {{Vec3i(0, 0, 0), 3.0f}, {Vec3i(2, 1, 1), 2.5f}}), &intensity,
       "label volume holds non-integer value 2.5 at voxel (2, 1, 1)"},
      {"negative.nrrd", small_field(Vec3i(4, 3, 2), {{Vec3i(1, 2, 0), -1.0f}}), &intensity,
       "label volume holds negative value -1 at voxel (1, 2, 0)"},
      {"large.nrrd", small_field(Vec3i(4, 3, 2), {{Vec3i(3, 2, 1), 2e7f}}), &intensity,
       "label volume holds label above 16777216, 2e+07 at voxel (3, 2, 1)"},
      {"size.nrrd", small_field(Vec3i(4, 3, 3), {}), &intensity,
       "label volume is 4x3x3 voxels but the intensity volume ct.nrrd is 4x3x2"},
      {"spacing.nrrd", small_field(Vec3i(4, 3, 2), {}), &coarse,
       "label volume spacing (1, 1, 1) mm differs from the intensity volume ct.nrrd's (1, 1, 2) "
       "mm"},
      {"origin.nrrd", small_field(Vec3i(4, 3, 2), {}), &shifted,
       "label volume origin (0, 0, 0) mm differs from the intensity volume ct.nrrd's (0, -3.5, 0) "
       "mm"},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.file;
    write_nrrd(c.labels, path);
    EXPECT_EQ(input_error_of([&] { read_label_volume(path, *c.intensity, "ct.nrrd"); }),
              path + ": " + c.problem);
  }
  EXPECT_EQ(
      input_error_of([&] { read_label_volume(dir + "/labels.png", intensity, "ct.nrrd"); }),
      dir +
          "/labels.png: unknown volume format (expected .nrrd, .nhdr, .vdb, .mha, .mhd, .nii, "
          ".nii.gz, .hdr, .dcm or .raw, a folder of DICOM slices, or a generator: block, sphere, "
          "four-spheres)");
}

// ---- picking ----------------------------------------------------------------------------

float solid(float density) { return density > 0.0f ? 1.0f : 0.0f; }

TEST(Picking, AnAxisRayHitsTheFirstSphereAtItsEntry) {
  const FourSpheres phantom{64, 1.0};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  // Along +x through a row of voxel centres near sphere 2's centre (c-d, c+d, c-d): the
  // other spheres are 2d = 0.35 n off this row in y or z, more than r = 0.18 n.
  const Vec3d c2 = phantom.centre(2);
  const int y = static_cast<int>(std::lround(c2.y()));
  const int z = static_cast<int>(std::lround(c2.z()));
  int first = -1;
  for (int x = 0; x < 64 && first < 0; ++x) {
    if (phantom.inside(2, Vec3i(x, y, z))) first = x;
  }
  ASSERT_GT(first, 0);
  const Vec3d origin(-5.0, y, z);
  const double r = phantom.radius();
  const double analytic_entry =
      c2.x() - std::sqrt(r * r - std::pow(y - c2.y(), 2) - std::pow(z - c2.z(), 2)) - origin.x();

  const auto hit = pick_voxel(intensity, origin, Vec3d(1.0, 0.0, 0.0), solid);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->voxel, Vec3i(first, y, z));
  EXPECT_NEAR(hit->depth_mm, analytic_entry, 1.0);
  EXPECT_DOUBLE_EQ(hit->depth_mm, first - 0.5 - origin.x());  // the voxel's entry face
  EXPECT_DOUBLE_EQ(hit->accumulated_opacity, 1.0);
  std::printf("axis pick: voxel x = %d, depth %.3f mm, analytic entry %.3f mm\n", first,
              hit->depth_mm, analytic_entry);

  // 0.1 per voxel: 1 - 0.9^6 = 0.469 < 0.5 <= 1 - 0.9^7 = 0.522, so the seventh voxel in; a
  // threshold of 0.9 needs 22 voxels (1 - 0.9^21 = 0.891 < 0.9 <= 1 - 0.9^22 = 0.902).
  const auto faint = [](float d) { return d > 0.0f ? 0.1f : 0.0f; };
  for (const auto& [threshold, voxels] : {std::pair(0.5, 7), std::pair(0.9, 22)}) {
    const auto hit_faint = pick_voxel(intensity, origin, Vec3d(1.0, 0.0, 0.0), faint, threshold);
    ASSERT_TRUE(hit_faint) << threshold;
    EXPECT_EQ(hit_faint->voxel, Vec3i(first + voxels - 1, y, z)) << threshold;
    EXPECT_NEAR(hit_faint->accumulated_opacity, 1.0 - std::pow(0.9, voxels), 1e-6) << threshold;
  }

  EXPECT_FALSE(pick_voxel(intensity, origin, Vec3d(1.0, 0.0, 0.0), [](float) { return 0.0f; }));
  EXPECT_FALSE(pick_voxel(intensity, origin, Vec3d(-1.0, 0.0, 0.0), solid));  // points away
  EXPECT_FALSE(pick_voxel(intensity, Vec3d(-5.0, -5.0, 10.0), Vec3d(1.0, 0.0, 0.0), solid));
}

TEST(Picking, OpacityIsPerVoxelOfPathAlongAnyDirection) {
  // A uniform volume with opacity 0.1 per smallest spacing (0.5 mm): after a path of L mm
  // inside, 1 - 0.9^(L / 0.5) is accumulated, so 0.5 is reached at L = 0.5 ln 0.5 / ln 0.9.
  const Vec3i dims(24, 12, 6);
  const Vec3d spacing(0.5, 1.0, 2.0);
  const RawVolume uniform = volume(dims, spacing, std::vector<float>(24 * 12 * 6, 1.0f));
  const double path_mm = 0.5 * std::log(0.5) / std::log(0.9);
  const auto faint = [](float) { return 0.1f; };
  // From outside the box's low corner at (-0.25, -0.5, -1) mm, or beside it along x.
  const std::vector<std::pair<Vec3d, Vec3d>> rays = {
      {Vec3d(-1.03, 3.2, 4.1), Vec3d(1.0, 0.0, 0.0)},
      {Vec3d(-1.03, -0.97, -1.1), Vec3d(1.0, 0.7, 0.3)},
      {Vec3d(-1.03, -0.97, -1.1), Vec3d(0.2, 0.9, 0.6)}};
  for (const auto& [origin, direction] : rays) {
    const Vec3d u = direction.normalized();
    // The ray enters the box at the largest of the per-axis entry distances.
    double t_in = 0.0;
    for (int a = 0; a < 3; ++a) {
      if (u[a] > 0.0) t_in = std::max(t_in, (-0.5 * spacing[a] - origin[a]) / u[a]);
    }
    const Vec3d crossing = origin + (t_in + path_mm) * u;
    const Vec3i expected = (crossing.cwiseQuotient(spacing).array() + 0.5).floor().cast<int>();
    const auto hit = pick_voxel(uniform, origin, direction, faint);
    ASSERT_TRUE(hit) << direction.transpose();
    EXPECT_EQ(hit->voxel, expected) << direction.transpose();
    EXPECT_LE(hit->depth_mm, t_in + path_mm) << direction.transpose();
    EXPECT_GE(hit->accumulated_opacity, 0.5) << direction.transpose();
    // What the voxel's own segment added: no more than its longest chord allows.
    const double before = 1.0 - std::pow(0.9, (hit->depth_mm - t_in) / 0.5);
    EXPECT_LT(before, 0.5) << direction.transpose();
  }
}

TEST(Picking, AnObliqueRayHitsWithinOneVoxelOfTheAnalyticEntry) {
  const FourSpheres phantom{64, 0.5};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  const double r_mm = phantom.radius() * phantom.voxel_mm;
  for (const Vec3d& outward : {Vec3d(1.0, 0.3, 0.2), Vec3d(0.6, 1.0, -0.1), Vec3d(0.3, 0.4, 1.0)}) {
    // From 40 mm out along `outward` from the blue sphere's centre, back towards it: the ray
    // leaves the box's +x/+y/+z corner region, where no other sphere lies.
    const Vec3d u = outward.normalized();
    const double distance = 40.0;
    const Vec3d origin = phantom.centre_mm(0) + distance * u;
    const auto hit = pick_voxel(intensity, origin, -u, solid);
    ASSERT_TRUE(hit) << outward.transpose();
    EXPECT_NEAR(hit->depth_mm, distance - r_mm, phantom.voxel_mm) << outward.transpose();
    EXPECT_TRUE(phantom.inside(0, hit->voxel)) << outward.transpose();
    std::printf("oblique pick: depth %.3f mm, analytic %.3f mm\n", hit->depth_mm, distance - r_mm);
  }
}

}  // namespace
}  // namespace hapvox::engine::labels
