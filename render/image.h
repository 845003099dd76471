#pragma once
// RGBA8 images (rows top to bottom), PNG files (libpng) and image comparison.

#include <cstdint>
#include <string>
#include <vector>

namespace hapvox::render {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // width * height * 4, row 0 is the top row

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgba(static_cast<std::size_t>(w) * h * 4, 0) {}
  std::uint8_t* pixel(int x, int y) { return &rgba[(static_cast<std::size_t>(y) * width + x) * 4]; }
  const std::uint8_t* pixel(int x, int y) const {
    return &rgba[(static_cast<std::size_t>(y) * width + x) * 4];
  }
};

/// Writes an 8-bit RGBA PNG to PATH.partial and renames it to PATH when complete.
/// Throws InputError(PATH, ...) when it cannot be written.
void write_png(const Image& image, const std::string& path);

/// Reads an 8-bit PNG (any colour type is converted to RGBA). Throws InputError(PATH, ...)
/// when the file is missing, not a PNG, or corrupt.
Image read_png(const std::string& path);

/// Peak signal-to-noise ratio of the RGB channels in dB (infinity for equal images).
/// The images must have the same size.
double psnr_db(const Image& a, const Image& b);

/// Mean absolute RGB difference per channel (0..255) inside the pixel box
/// [x0, x1) x [y0, y1), clipped to the image.
double mean_abs_difference(const Image& a, const Image& b, int x0, int y0, int x1, int y1);

}  // namespace hapvox::render
