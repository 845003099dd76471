#include "engine/labels/materials.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
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
using ::hapvox::testing::source_path;

const char kGood[] = R"(# two materials and a box
[[material]]
label = 0
youngs_modulus_pa = 2e5
poisson_ratio = 0.3

[[material]]
label = 7
name = "bone"
youngs_modulus_pa = 15_000_000_000
poisson_ratio = -0.2
fixed = true
intensity = [300, 3000]
density = 0.75
yield_stress_pa = 2e6

[[fixed_region]]
min_mm = [0, 0, 0]
max_mm = [1.5, 2, 3]
)";

TEST(Materials, ParsesEveryKey) {
  const Materials m = parse_materials(kGood, "m.toml");
  EXPECT_EQ(m.source, "m.toml");
  ASSERT_EQ(m.materials.size(), 2u);
  EXPECT_EQ(m.materials[0].label, 0);
  EXPECT_EQ(m.materials[0].name, "");
  EXPECT_EQ(m.materials[0].elastic.youngs_modulus_pa, 2e5);
  EXPECT_EQ(m.materials[0].elastic.poisson_ratio, 0.3);
  EXPECT_FALSE(m.materials[0].fixed);
  EXPECT_FALSE(m.materials[0].intensity);
  EXPECT_EQ(m.materials[0].line, 2);
  EXPECT_FALSE(m.materials[0].density);
  EXPECT_FALSE(m.materials[0].yield_stress_pa);
  EXPECT_EQ(m.materials[0].voxel_density(), 0.0);  // the background stays empty
  const Material* bone = m.find(7);
  ASSERT_NE(bone, nullptr);
  EXPECT_EQ(bone->name, "bone");
  EXPECT_EQ(bone->elastic.youngs_modulus_pa, 15e9);  // an integer is a number too
  EXPECT_EQ(bone->elastic.poisson_ratio, -0.2);
  EXPECT_TRUE(bone->fixed);
  ASSERT_TRUE(bone->intensity);
  EXPECT_EQ(bone->intensity->label, 7);
  EXPECT_EQ(bone->intensity->low, 300.0);
  EXPECT_EQ(bone->intensity->high, 3000.0);
  EXPECT_EQ(bone->line, 7);
  EXPECT_EQ(bone->density, 0.75);
  EXPECT_EQ(bone->voxel_density(), 0.75);
  EXPECT_EQ(bone->yield_stress_pa, 2e6);
  Material unnamed;
  unnamed.label = 3;
  EXPECT_EQ(unnamed.voxel_density(), 1.0);  // a label without a density is full
  EXPECT_EQ(m.find(3), nullptr);
  ASSERT_EQ(m.intensity_ranges().size(), 1u);
  EXPECT_EQ(m.intensity_ranges()[0].label, 7);
  EXPECT_EQ(m.fixed_labels(), std::set<Label>{7});
  ASSERT_EQ(m.fixed_regions.size(), 1u);
  EXPECT_EQ(m.fixed_regions[0].side, FixedRegion::Side::kNone);
  EXPECT_FALSE(m.fixed_regions[0].label);
  EXPECT_EQ(m.fixed_regions[0].min_mm, Vec3d(0.0, 0.0, 0.0));
  EXPECT_EQ(m.fixed_regions[0].max_mm, Vec3d(1.5, 2.0, 3.0));
  EXPECT_EQ(m.fixed_regions[0].line, 17);
}

// Each bad file gives exactly this one line (what() of the InputError, as the CLI prints it
// after "hapvox: error: ").
struct BadFile {
  std::string text;
  std::string message;
};

const char kMaterial1[] = "[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.3\n";

TEST(Materials, EachBadFileGivesItsOneLine) {
  const std::string ok = kMaterial1;
  const std::vector<BadFile> cases = {
      // TOML syntax, with toml++'s position and words.
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = = 2\n",
       "m.toml:3: Error while parsing value: could not determine value type"},
      {"[[material]]\nlabel = 1\nlabel = 2\n",
       "m.toml:3: Error while parsing key-value pair: cannot redefine existing integer 'label'"},
      {"[[material]]\nname = \"\xff\"\n", "m.toml:2: Encountered invalid utf-8 sequence"},
      // The whole file.
      {"", "m.toml: no [[material]] tables (see docs/materials.md)"},
      {"# nothing\n[[fixed_region]]\nmin_mm = [0, 0, 0]\nmax_mm = [1, 1, 1]\n",
       "m.toml: no [[material]] tables (see docs/materials.md)"},
      {"density = 3\n",
       "m.toml:1: unknown key 'density' (expected [[material]] or "
       "[[fixed_region]] tables)"},
      {"[material]\nlabel = 1\n",
       "m.toml:1: material must be an array of tables: write "
       "[[material]]"},
      {"material = [1, 2]\n",
       "m.toml:1: material must be an array of tables: write "
       "[[material]]"},
      // Missing keys: at the table's header.
      {"\n[[material]]\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.3\n",
       "m.toml:2: [[material]] has no label"},
      {"[[material]]\nlabel = 1\npoisson_ratio = 0.3\n",
       "m.toml:1: [[material]] for label 1 has no youngs_modulus_pa"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e6\n",
       "m.toml:1: [[material]] for label 1 has no poisson_ratio"},
      // Wrong types.
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = \"1e6\"\npoisson_ratio = 0.3\n",
       "m.toml:3: youngs_modulus_pa must be a number, got a string"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e6\npoisson_ratio = [0.3]\n",
       "m.toml:4: poisson_ratio must be a number, got an array"},
      {"[[material]]\nlabel = 1.0\n", "m.toml:2: label must be an integer, got a float"},
      {"[[material]]\nlabel = \"white\"\n", "m.toml:2: label must be an integer, got a string"},
      {"[[material]]\nlabel = -2\n", "m.toml:2: label must lie in [0, 16777216], got -2"},
      {"[[material]]\nlabel = 16777217\n",
       "m.toml:2: label must lie in [0, 16777216], got 16777217"},
      {"[[material]]\nlabel = 1\nname = 3\n", "m.toml:3: name must be a string, got an integer"},
      {"[[material]]\nlabel = 1\nfixed = \"yes\"\n",
       "m.toml:3: fixed must be true or false, got a string"},
      {"[[material]]\nlabel = 1\nintensity = [0.5]\n",
       "m.toml:3: intensity must be an array [low, high] of two numbers"},
      {"[[material]]\nlabel = 1\nintensity = [0.5, \"1\"]\n",
       "m.toml:3: intensity must be an array [low, high] of two numbers"},
      {"[[material]]\nlabel = 1\nintensity = [0.6, 0.4]\n",
       "m.toml:3: intensity range [0.6, 0.4] has low above high"},
      {"[[material]]\nlabel = 1\nintensity = [0, nan]\n",
       "m.toml:3: intensity must hold finite numbers"},
      // Values out of range.
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = 0\npoisson_ratio = 0.3\n",
       "m.toml:3: Young's modulus must be positive and finite, got 0 Pa"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = -5e3\npoisson_ratio = 0.3\n",
       "m.toml:3: Young's modulus must be positive and finite, got -5000 Pa"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = inf\npoisson_ratio = 0.3\n",
       "m.toml:3: Young's modulus must be positive and finite, got inf Pa"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e6\n\n\npoisson_ratio = 0.5\n",
       "m.toml:6: Poisson's ratio must lie in (-1, 0.5), got 0.5"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e6\npoisson_ratio = -1\n",
       "m.toml:4: Poisson's ratio must lie in (-1, 0.5), got -1"},
      {"[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e6\npoisson_ratio = nan\n",
       "m.toml:4: Poisson's ratio must lie in (-1, 0.5), got nan"},
      {"[[material]]\nlabel = 1\ndensity = 1.5\n", "m.toml:3: density must lie in [0, 1], got 1.5"},
      {"[[material]]\nlabel = 1\ndensity = -0.1\n",
       "m.toml:3: density must lie in [0, 1], got -0.1"},
      {"[[material]]\nlabel = 1\ndensity = nan\n", "m.toml:3: density must lie in [0, 1], got nan"},
      {"[[material]]\nlabel = 1\ndensity = \"full\"\n",
       "m.toml:3: density must be a number, got a string"},
      {"[[material]]\nlabel = 1\nyield_stress_pa = 0\n",
       "m.toml:3: yield stress must be positive and finite, got 0 Pa"},
      {"[[material]]\nlabel = 1\nyield_stress_pa = inf\n",
       "m.toml:3: yield stress must be positive and finite, got inf Pa"},
      // Of two problems, the first in the file is reported (toml++ keeps keys sorted).
      {"[[material]]\nyoungs_modulus_pa = \"x\"\nlabel = 1.5\n",
       "m.toml:2: youngs_modulus_pa must be a number, got a string"},
      // Duplicates and unknown keys.
      {ok + "\n" + ok, "m.toml:7: label 1 is given twice (first at line 1)"},
      {"[[material]]\nlabel = 1\nyoungs_modulus = 1e6\n",
       "m.toml:3: unknown key 'youngs_modulus' in [[material]] (expected label, name, "
       "youngs_modulus_pa, poisson_ratio, fixed, intensity, density, yield_stress_pa)"},
      {"[[material]]\nlabel = 1\nelastic = { e = 1 }\n",
       "m.toml:3: unknown key 'elastic' in [[material]] (expected label, name, "
       "youngs_modulus_pa, poisson_ratio, fixed, intensity, density, yield_stress_pa)"},
      // Fixed regions.
      {ok + "[[fixed_region]]\nlabel = 1\n",
       "m.toml:5: [[fixed_region]] needs either side (with label) or min_mm and max_mm"},
      {ok + "[[fixed_region]]\nlabel = 1\nside = \"left\"\n",
       "m.toml:7: side must be one of -x, +x, -y, +y, -z, +z, got 'left'"},
      {ok + "[[fixed_region]]\nlabel = 1\nside = 1\n",
       "m.toml:7: side must be one of -x, +x, -y, +y, -z, +z, got an integer"},
      {ok + "[[fixed_region]]\nside = \"+y\"\n",
       "m.toml:6: side needs a label: the side of which label's extent"},
      {ok + "[[fixed_region]]\nlabel = 1\nside = \"+y\"\nfraction = 0\n",
       "m.toml:8: fraction must lie in (0, 1], got 0"},
      {ok + "[[fixed_region]]\nmin_mm = [0, 0, 0]\nmax_mm = [1, 1, 1]\nfraction = 0.5\n",
       "m.toml:8: fraction needs a side"},
      {ok + "[[fixed_region]]\nlabel = 1\nside = \"-z\"\nmin_mm = [0, 0, 0]\n",
       "m.toml:5: [[fixed_region]] takes either side or min_mm and max_mm, not both"},
      {ok + "[[fixed_region]]\nmin_mm = [0, 0]\nmax_mm = [1, 1, 1]\n",
       "m.toml:6: min_mm must be an array [x, y, z] of three numbers"},
      {ok + "[[fixed_region]]\nmin_mm = [0, 2, 0]\nmax_mm = [1, 1, 1]\n",
       "m.toml:6: min_mm must lie below max_mm on every axis"},
      {ok + "[[fixed_region]]\nlabel = 1\ncorner = \"-x\"\n",
       "m.toml:7: unknown key 'corner' in [[fixed_region]] (expected label, side, fraction, "
       "min_mm, max_mm)"},
  };
  for (const BadFile& c : cases) {
    EXPECT_EQ(input_error_of([&] { parse_materials(c.text, "m.toml"); }), c.message)
        << "for the file:\n"
        << c.text;
  }
  // The good file passes, so each case fails for the reason it names.
  EXPECT_NO_THROW(parse_materials(ok, "m.toml"));
}

TEST(Materials, AFileThatCannotBeReadIsNamed) {
  const std::string dir = scratch_dir();
  EXPECT_EQ(input_error_of([&] { read_materials(dir + "/none.toml"); }),
            dir + "/none.toml: cannot open file");
  EXPECT_EQ(input_error_of([&] { read_materials(dir); }), dir + ": is a directory");
  std::ofstream(dir + "/bad.toml") << kMaterial1 << "poisson_ratio = 0.7\n";
  EXPECT_EQ(input_error_of([&] { read_materials(dir + "/bad.toml"); }),
            dir +
                "/bad.toml:5: Error while parsing key-value pair: cannot redefine existing "
                "floating-point 'poisson_ratio'");
}

TEST(Materials, NestingPastTheDepthLimitIsRefusedBeforeTomlReadsIt) {
  // A header of 30,000 dotted key parts (60 kB) overflowed the stack inside toml++.
  std::string dotted = "[a";
  for (int i = 0; i < 30000; ++i) dotted += ".a";
  EXPECT_EQ(input_error_of([&] { parse_materials(kMaterial1 + dotted + "]\n", "m.toml"); }),
            "m.toml:5: nests 30002 levels deep (tables, dotted keys, arrays and inline tables), "
            "over the limit of 64");
  const std::string arrays = "x = " + std::string(65, '[') + std::string(65, ']') + "\n";
  EXPECT_EQ(input_error_of([&] { parse_materials(arrays, "m.toml"); }),
            "m.toml:1: nests 65 levels deep (tables, dotted keys, arrays and inline tables), "
            "over the limit of 64");
  // Dots in strings and comments are no keys; numbers count, and stay far from the limit.
  std::string dots;
  for (int i = 0; i < 100; ++i) dots += "a.";
  const std::string quiet =
      std::string(kMaterial1) + "name = '" + dots + "'  # " + dots + "\nintensity = [1.5, 2.5]\n";
  EXPECT_EQ(parse_materials(quiet, "m.toml").materials.front().name, dots);
}

TEST(Materials, ManyMaterialsParseInLinearTime) {
  // The duplicate check searched the materials so far: 200,000 took 97 s. Not timed (a
  // test is no benchmark); 100,000 labels with the last one repeated names both lines.
  std::string text;
  for (int label = 1; label <= 100000; ++label) {
    text += "[[material]]\nlabel = " + std::to_string(label) +
            "\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.3\n";
  }
  EXPECT_EQ(parse_materials(text, "m.toml").materials.size(), 100000u);
  text += "[[material]]\nlabel = 100000\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.3\n";
  EXPECT_EQ(input_error_of([&] { parse_materials(text, "m.toml"); }),
            "m.toml:400002: label 100000 is given twice (first at line 399997)");
}

// ---- the bundled four-spheres file ------------------------------------------------------

TEST(FourSpheresMaterials, GiveEachSphereItsFig5Modulus) {
  const Materials m = read_materials(source_path("data/four_spheres.toml"));
  ASSERT_EQ(m.materials.size(), 5u);
  const FourSpheres phantom{48, 1.0};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  // The file's intensity ranges label the phantom exactly as seeds at the centres do.
  std::vector<Seed> seeds;
  for (int s = 0; s < 4; ++s) seeds.push_back(Seed{phantom.centre_mm(s), s + 1});
  const LabelMap grown = grow_regions(intensity, seeds, 0.05, "seeds");
  const LabelMap map = labels_from_intensity_ranges(intensity, m.intensity_ranges());
  EXPECT_EQ(map.data(), grown.data());
  EXPECT_NO_THROW(check_labels_have_materials(map, m));
  // Fig. 5: green 100 MPa, blue 0.1 MPa, red and background 10 MPa, white 1 MPa; colours by
  // intensity (0.4 blue, 0.6 green, 0.8 red, 1.0 white), as the file's comment says.
  const std::vector<std::pair<std::string, double>> expected = {
      {"blue", 0.1e6}, {"green", 100e6}, {"red", 10e6}, {"white", 1e6}};
  for (int s = 0; s < 4; ++s) {
    const Material* material = m.find(map.at_world(phantom.centre_mm(s)));
    ASSERT_NE(material, nullptr) << s;
    EXPECT_EQ(material->name, expected[s].first) << s;
    EXPECT_EQ(material->elastic.youngs_modulus_pa, expected[s].second) << s;
    EXPECT_EQ(material->elastic.poisson_ratio, 0.45) << s;
    EXPECT_FALSE(material->fixed) << s;
  }
  const Material* background = m.find(map.at_world(Vec3d(0.0, 0.0, 0.0)));
  ASSERT_NE(background, nullptr);
  EXPECT_EQ(background->name, "background");
  EXPECT_EQ(background->elastic.youngs_modulus_pa, 10e6);
}

TEST(FourSpheresMaterials, FixTheLeftSideOfTheWhiteSphereOnly) {
  const Materials m = read_materials(source_path("data/four_spheres.toml"));
  const FourSpheres phantom{48, 0.5};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  const LabelMap map = labels_from_intensity_ranges(intensity, m.intensity_ranges());
  const std::vector<std::uint8_t> fixed = fixed_voxels(map, m);
  // The white sphere (3, label 4) spans centre.x +- r; its left quarter ends at centre.x - r/2
  // (to within the voxelisation: the label's extent is the voxels', faces included).
  const double cut = phantom.centre(3).x() - 0.5 * phantom.radius();
  std::int64_t fixed_count = 0;
  for (int z = 0; z < phantom.n; ++z) {
    for (int y = 0; y < phantom.n; ++y) {
      for (int x = 0; x < phantom.n; ++x) {
        const Vec3i ijk(x, y, z);
        const bool is_fixed = fixed[static_cast<std::size_t>(map.linear_index(ijk))] != 0;
        fixed_count += is_fixed ? 1 : 0;
        if (!phantom.inside(3, ijk)) {
          ASSERT_FALSE(is_fixed) << ijk.transpose();
        } else if (x < cut - 1.0) {
          ASSERT_TRUE(is_fixed) << ijk.transpose();
        } else if (x > cut + 1.0) {
          ASSERT_FALSE(is_fixed) << ijk.transpose();
        }
      }
    }
  }
  // Exactly: the sphere's voxels whose centres lie in the first quarter of its voxels' extent
  // in x, faces included.
  int lo = phantom.n;
  int hi = -1;
  for (int z = 0; z < phantom.n; ++z) {
    for (int y = 0; y < phantom.n; ++y) {
      for (int x = 0; x < phantom.n; ++x) {
        if (phantom.inside(3, Vec3i(x, y, z))) lo = std::min(lo, x), hi = std::max(hi, x);
      }
    }
  }
  const double quarter = (lo - 0.5) + 0.25 * (hi - lo + 1);
  std::int64_t expected = 0;
  for (int z = 0; z < phantom.n; ++z) {
    for (int y = 0; y < phantom.n; ++y) {
      for (int x = 0; x <= quarter; ++x) expected += phantom.inside(3, Vec3i(x, y, z)) ? 1 : 0;
    }
  }
  EXPECT_EQ(fixed_count, expected);
  // A cap of height r/2 holds pi h^2 (3r - h) / 3 = 5/24 pi r^3 voxels; the voxelised one
  // differs by up to a slice.
  const double cap = 5.0 / 24.0 * std::acos(-1.0) * std::pow(phantom.radius(), 3);
  std::printf("fixed voxels: %lld, analytic cap %.1f\n", static_cast<long long>(fixed_count), cap);
}

TEST(FixedRegions, BoxesAndFixedMaterialsFixTheirVoxels) {
  // 6x5x4 voxels of 0.5 mm at (1, 2, 3): label 2 in the x >= 3 half; label 2 is fixed, and a
  // box fixes voxel centres in [1, 1.6] x [2, 2.6] x [3, 4] mm whatever their label.
  LabelMap map(Vec3i(6, 5, 4), Vec3d::Constant(0.5), Vec3d(1.0, 2.0, 3.0));
  for (int z = 0; z < 4; ++z) {
    for (int y = 0; y < 5; ++y) {
      for (int x = 3; x < 6; ++x) map.set(Vec3i(x, y, z), 2);
    }
  }
  const Materials m = parse_materials(
      "[[material]]\nlabel = 0\nyoungs_modulus_pa = 1\npoisson_ratio = 0\n"
      "[[material]]\nlabel = 2\nyoungs_modulus_pa = 1\npoisson_ratio = 0\nfixed = true\n"
      "[[fixed_region]]\nmin_mm = [1, 2, 3]\nmax_mm = [1.6, 2.6, 4]\n",
      "m.toml");
  const std::vector<std::uint8_t> fixed = fixed_voxels(map, m);
  for (int z = 0; z < 4; ++z) {
    for (int y = 0; y < 5; ++y) {
      for (int x = 0; x < 6; ++x) {
        const bool in_box = x <= 1 && y <= 1 && z <= 2;  // centres 1 + 0.5 x <= 1.6, ...
        EXPECT_EQ(fixed[static_cast<std::size_t>(map.linear_index(Vec3i(x, y, z)))] != 0,
                  in_box || x >= 3)
            << x << " " << y << " " << z;
      }
    }
  }
  // A side of a label the map does not hold.
  const Materials side =
      parse_materials(std::string(kMaterial1) +
                          "[[material]]\nlabel = 0\nyoungs_modulus_pa = 1\n"
                          "poisson_ratio = 0\n[[fixed_region]]\nlabel = 1\nside = \"+z\"\n",
                      "m.toml");
  EXPECT_EQ(input_error_of([&] { resolve_fixed_regions(side, map); }),
            "m.toml:9: [[fixed_region]] names label 1, which the label map does not hold");
}

TEST(Materials, ALabelWithoutMaterialIsNamedWithItsVoxelCount) {
  const FourSpheres phantom{32, 1.0};
  const RawVolume intensity = dense_intensity(generate_volume(phantom.spec()));
  const LabelMap map = labels_from_intensity_ranges(
      intensity, {{1, 0.35, 0.45}, {2, 0.55, 0.65}, {3, 0.75, 0.85}, {4, 0.95, 1.05}});
  const std::string others =
      "[[material]]\nlabel = 1\nyoungs_modulus_pa = 1e5\npoisson_ratio = 0.45\n"
      "[[material]]\nlabel = 2\nyoungs_modulus_pa = 1e8\npoisson_ratio = 0.45\n"
      "[[material]]\nlabel = 4\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.45\n";
  const std::string background =
      "[[material]]\nlabel = 0\nyoungs_modulus_pa = 1e7\npoisson_ratio = 0.45\n";
  const std::int64_t red = phantom.lattice_count(2);
  const std::int64_t rest = 32 * 32 * 32 - red - phantom.lattice_count(0) -
                            phantom.lattice_count(1) - phantom.lattice_count(3);
  EXPECT_EQ(input_error_of([&] {
              check_labels_have_materials(map, parse_materials(others + background, "m.toml"));
            }),
            "m.toml: label 3 has no material (" + std::to_string(red) + " voxels)");
  EXPECT_EQ(
      input_error_of([&] { check_labels_have_materials(map, parse_materials(others, "m.toml")); }),
      "m.toml: labels 0 (" + std::to_string(rest) + " voxels), 3 (" + std::to_string(red) +
          " voxels) have no material");
  EXPECT_EQ(input_error_of([&] { fixed_voxels(map, parse_materials(others, "m.toml")); }),
            "m.toml: labels 0 (" + std::to_string(rest) + " voxels), 3 (" + std::to_string(red) +
                " voxels) have no material");
  std::printf("red sphere: %lld voxels, background %lld\n", static_cast<long long>(red),
              static_cast<long long>(rest));
}

}  // namespace
}  // namespace hapvox::engine::labels
