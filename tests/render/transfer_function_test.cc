#include "render/transfer_function.h"

#include <gtest/gtest.h>

#include <fstream>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::render {
namespace {

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string error_of(const std::string& spec) {
  try {
    TransferFunction::from_spec(spec);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(TransferFunction, InterpolatesLinearlyBetweenPointsAndHoldsOutside) {
  const TransferFunction tf({{0.25f, 0.0f, 0.0f, 0.0f, 0.0f}, {0.75f, 1.0f, 0.5f, 0.0f, 1.0f}},
                            "test");
  EXPECT_FLOAT_EQ(tf.entry(0)[3], 0.0f);
  EXPECT_FLOAT_EQ(tf.entry(255)[0], 1.0f);
  EXPECT_FLOAT_EQ(tf.entry(255)[1], 0.5f);
  // Halfway between the points (density 0.5 is entry 127.5): half the colour.
  const float d127 = 127.0f / 255.0f;
  EXPECT_NEAR(tf.entry(127)[0], (d127 - 0.25f) / 0.5f, 1e-6);
  EXPECT_NEAR(tf.entry(127)[3], (d127 - 0.25f) / 0.5f, 1e-6);
  EXPECT_NEAR(tf.first_visible_density(), 0.25f, 1.0f / 255.0f);
}

TEST(TransferFunction, PresetsExistAndShowDenseMaterial) {
  for (const std::string& name : TransferFunction::preset_names()) {
    const TransferFunction tf = TransferFunction::from_spec(name);
    EXPECT_FLOAT_EQ(tf.entry(0)[3], 0.0f) << name;  // empty space is invisible
    EXPECT_GT(tf.entry(255)[3], 0.8f) << name;      // normal density is nearly opaque
  }
}

TEST(TransferFunction, FileRoundTripsThePresetTable) {
  const std::string path = testing::scratch_dir() + "/tf.txt";
  write(path, "# density r g b a\n0.0 0 0 0 0\n\n0.5 0.2 0.4 0.6 0.1  # mid\n1.0 1 1 1 1\n");
  const TransferFunction tf = TransferFunction::from_spec(path);
  EXPECT_NEAR(tf.entry(255)[2], 1.0f, 1e-6);
  EXPECT_NEAR(tf.entry(0)[0], 0.0f, 1e-6);
  const TransferFunction direct({{0, 0, 0, 0, 0}, {0.5f, 0.2f, 0.4f, 0.6f, 0.1f}, {1, 1, 1, 1, 1}},
                                "x");
  for (int i = 0; i < TransferFunction::kSize; ++i) {
    for (int c = 0; c < 4; ++c) EXPECT_FLOAT_EQ(tf.entry(i)[c], direct.entry(i)[c]);
  }
}

TEST(TransferFunction, BadFilesNameTheFileLineAndProblem) {
  const std::string dir = testing::scratch_dir();
  write(dir + "/short.txt", "0 0 0 0 0\n1 1 1 1\n");
  EXPECT_EQ(error_of(dir + "/short.txt"),
            dir + "/short.txt:2: expected 'density r g b a' (five numbers)");
  write(dir + "/word.txt", "0 0 0 0 0\nhello\n");
  EXPECT_EQ(error_of(dir + "/word.txt"),
            dir + "/word.txt:2: expected 'density r g b a' (five numbers)");
  write(dir + "/one.txt", "0.5 1 1 1 1\n");
  EXPECT_EQ(error_of(dir + "/one.txt"), dir + "/one.txt: needs at least two control points");
  write(dir + "/order.txt", "0.5 1 1 1 1\n0.5 0 0 0 0\n");
  EXPECT_EQ(error_of(dir + "/order.txt"),
            dir + "/order.txt: control point 2: densities must increase strictly");
  write(dir + "/range.txt", "0 0 0 0 0\n1 2 0 0 1\n");
  EXPECT_EQ(error_of(dir + "/range.txt"),
            dir + "/range.txt: control point 2: values must lie in [0, 1]");
  write(dir + "/nan.txt", "0 0 0 0 0\n1 nan 0 0 1\n");
  EXPECT_NE(error_of(dir + "/nan.txt").find(dir + "/nan.txt"), std::string::npos);
  EXPECT_EQ(error_of("no-such-preset"),
            "no-such-preset: not a transfer-function preset (clay, ct-bone, ct-soft) or a file");
}

}  // namespace
}  // namespace hapvox::render
