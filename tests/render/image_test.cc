#include "render/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "engine/errors.h"
#include "test_data.h"

namespace hapvox::render {
namespace {

Image gradient_image(int w, int h) {
  Image image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      std::uint8_t* p = image.pixel(x, y);
      p[0] = static_cast<std::uint8_t>(x * 255 / (w - 1));
      p[1] = static_cast<std::uint8_t>(y * 255 / (h - 1));
      p[2] = static_cast<std::uint8_t>((x + y) % 256);
      p[3] = 255;
    }
  }
  return image;
}

TEST(Png, RoundTripIsExactAndLeavesNoPartialFile) {
  const std::string dir = testing::scratch_dir();
  const Image image = gradient_image(37, 21);
  write_png(image, dir + "/a.png");
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.png.partial"));
  const Image back = read_png(dir + "/a.png");
  ASSERT_EQ(back.width, 37);
  ASSERT_EQ(back.height, 21);
  EXPECT_EQ(back.rgba, image.rgba);
  EXPECT_TRUE(std::isinf(psnr_db(image, back)));
}

TEST(Png, BadFilesNameTheFileAndProblem) {
  const std::string dir = testing::scratch_dir();
  std::ofstream(dir + "/text.png") << "not a png at all";
  EXPECT_THROW(
      {
        try {
          read_png(dir + "/text.png");
        } catch (const InputError& e) {
          EXPECT_EQ(std::string(e.what()), dir + "/text.png: not a PNG file");
          throw;
        }
      },
      InputError);
  write_png(gradient_image(64, 64), dir + "/whole.png");
  std::filesystem::resize_file(dir + "/whole.png", 200);  // truncated
  try {
    read_png(dir + "/whole.png");
    ADD_FAILURE() << "a truncated PNG was read";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(dir + "/whole.png: corrupt PNG: ", 0), 0u) << e.what();
  }
  try {
    write_png(gradient_image(8, 8), dir + "/no/such/dir/x.png");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              dir + "/no/such/dir/x.png: output directory " + dir + "/no/such/dir does not exist");
  }
}

TEST(Psnr, MatchesTheDefinition) {
  Image a(10, 10), b(10, 10);
  for (std::size_t i = 0; i < b.rgba.size(); i += 4) b.rgba[i] = 10;  // red off by 10
  // MSE over RGB = 100 / 3.
  EXPECT_NEAR(psnr_db(a, b), 10.0 * std::log10(255.0 * 255.0 * 3.0 / 100.0), 1e-9);
  EXPECT_NEAR(mean_abs_difference(a, b, 0, 0, 10, 10), 10.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(mean_abs_difference(a, b, 0, 0, 0, 0), 0.0);
}

}  // namespace
}  // namespace hapvox::render
