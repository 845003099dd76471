#include "engine/proxy/label_source.h"

#include <gtest/gtest.h>

#include "../labels/input_error.h"
#include "phantom_inputs.h"

namespace hapvox::engine::proxy {
namespace {

using testing::input_error_of;

// 24^3: small enough for every test to make its own.
struct Inputs : testing::PhantomInputs {
  Inputs() : PhantomInputs(24) {}
};

TEST(ProxyLabels, WithoutLabelsOrSeedsTheMaterialsIntensityRangesLabel) {
  const Inputs in;
  const labels::LabelMap map = proxy_labels(in.intensity, in.materials, {});
  EXPECT_EQ(
      map.data(),
      labels::labels_from_intensity_ranges(in.intensity, in.materials.intensity_ranges()).data());
  const auto counts = map.voxel_counts();
  for (int s = 0; s < 4; ++s) EXPECT_EQ(counts.at(s + 1), in.spheres.lattice_count(s));
}

TEST(ProxyLabels, SeedsGrowTheirRegions) {
  const Inputs in;
  LabelSourceOptions options;
  options.seeds = {{in.spheres.centre_mm(3), 7}, {in.spheres.centre_mm(1), 2}};
  options.seed_tolerance = 0.05;
  const labels::LabelMap map = proxy_labels(in.intensity, in.materials, options);
  const auto counts = map.voxel_counts();
  ASSERT_EQ(counts.size(), 3u);
  EXPECT_EQ(counts.at(7), in.spheres.lattice_count(3));
  EXPECT_EQ(counts.at(2), in.spheres.lattice_count(1));
  // The default tolerance, a tenth of the intensity range (0.1 here), gives the same spheres.
  options.seed_tolerance.reset();
  EXPECT_EQ(proxy_labels(in.intensity, in.materials, options).data(), map.data());
}

TEST(ProxyLabels, ALabelVolumeWinsOverTheIntensityRanges) {
  const Inputs in;
  LabelSourceOptions options;
  options.label_volume = "four-spheres:dims=24,voxel_mm=1";  // densities 0, 0.4 ... are no labels
  options.intensity_name = "phantom";
  EXPECT_EQ(input_error_of([&] {
              proxy_labels(in.intensity, in.materials, options);
            }).rfind("four-spheres:dims=24,voxel_mm=1: ", 0),
            0u);
  options.label_volume = "block:dims=24,voxel_mm=1";  // 0 and 1: integers, so labels
  const labels::LabelMap map = proxy_labels(in.intensity, in.materials, options);
  EXPECT_EQ(map.voxel_counts().at(1), 24 * 24 * 12);
}

TEST(ProxyLabels, EachMistakeIsOneInputError) {
  const Inputs in;
  LabelSourceOptions both;
  both.label_volume = "labels.nrrd";
  both.seeds = {{Vec3d(1, 1, 1), 1}};
  EXPECT_EQ(input_error_of([&] { proxy_labels(in.intensity, in.materials, both); }),
            "--seed: seeds cannot be combined with a label volume (labels.nrrd)");

  const labels::Materials no_ranges = labels::parse_materials(
      "[[material]]\nlabel = 0\nyoungs_modulus_pa = 1e6\npoisson_ratio = 0.3\n", "plain.toml");
  EXPECT_EQ(input_error_of([&] { proxy_labels(in.intensity, no_ranges, {}); }),
            "plain.toml: no labels: the file gives no intensity ranges, and no label volume "
            "(--labels) or seeds (--seed) were given");

  LabelSourceOptions outside;
  outside.seeds = {{Vec3d(100, 1, 1), 1}};
  EXPECT_EQ(input_error_of([&] {
              proxy_labels(in.intensity, in.materials, outside);
            }).rfind("--seed: ", 0),
            0u);
}

}  // namespace
}  // namespace hapvox::engine::proxy
