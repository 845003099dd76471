#include "render/image.h"

#include <png.h>
#include <unistd.h>

#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/io/output_file.h"

namespace hapvox::render {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// libpng reports errors by longjmp; the message is kept here so the caller can throw
// a typed error after the jump (C++ exceptions must not cross libpng's C frames).
struct PngErrorText {
  char text[256] = "";
};
void on_png_error(png_structp png, png_const_charp message) {
  auto* error = static_cast<PngErrorText*>(png_get_error_ptr(png));
  std::snprintf(error->text, sizeof error->text, "%s", message);
  longjmp(png_jmpbuf(png), 1);
}
void on_png_warning(png_structp, png_const_charp) {}

}  // namespace

void write_png(const Image& image, const std::string& path) {
  HAPVOX_CHECK_EQ(image.rgba.size(), static_cast<std::size_t>(image.width) * image.height * 4);
  // Through PATH.partial, renamed once complete (engine/io/output_file.h).
  engine::io::OutputFile out(path);
  File file(fdopen(dup(out.fd()), "wb"));
  if (!file) {
    out.discard();
    throw InputError(path, "cannot be written");
  }
  PngErrorText error;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, on_png_error, on_png_warning);
  png_infop info = png_create_info_struct(png);
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y) {
    rows[y] = const_cast<png_bytep>(image.pixel(0, y));
  }
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_write_struct(&png, &info);
    file.reset();
    out.discard();
    throw InputError(path, std::string("cannot be written: ") + error.text);
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 3);  // frames are written often: speed over size
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fclose(file.release()) != 0) {
    out.discard();
    throw InputError(path, "cannot be written (disk full?)");
  }
  out.commit();
}

Image read_png(const std::string& path) {
  File file(std::fopen(path.c_str(), "rb"));
  if (!file) throw InputError(path, "cannot be opened");
  png_byte signature[8] = {};
  if (std::fread(signature, 1, 8, file.get()) != 8 || png_sig_cmp(signature, 0, 8) != 0) {
    throw InputError(path, "not a PNG file");
  }
  PngErrorText error;
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &error, on_png_error, on_png_warning);
  png_infop info = png_create_info_struct(png);
  Image image;
  std::vector<png_bytep> rows;
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw InputError(path, std::string("corrupt PNG: ") + error.text);
  }
  png_init_io(png, file.get());
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  png_set_expand(png);
  png_set_strip_16(png);
  png_set_gray_to_rgb(png);
  png_set_add_alpha(png, 0xff, PNG_FILLER_AFTER);
  png_read_update_info(png, info);
  image = Image(static_cast<int>(png_get_image_width(png, info)),
                static_cast<int>(png_get_image_height(png, info)));
  rows.resize(static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y) rows[y] = image.pixel(0, y);
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return image;
}

double psnr_db(const Image& a, const Image& b) {
  HAPVOX_CHECK_EQ(a.width, b.width);
  HAPVOX_CHECK_EQ(a.height, b.height);
  double sum = 0.0;
  for (std::size_t i = 0; i < a.rgba.size(); i += 4) {
    for (int c = 0; c < 3; ++c) {
      const double d = static_cast<double>(a.rgba[i + c]) - b.rgba[i + c];
      sum += d * d;
    }
  }
  const double mse = sum / (3.0 * a.width * a.height);
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

double mean_abs_difference(const Image& a, const Image& b, int x0, int y0, int x1, int y1) {
  HAPVOX_CHECK_EQ(a.width, b.width);
  HAPVOX_CHECK_EQ(a.height, b.height);
  x0 = std::max(x0, 0), y0 = std::max(y0, 0);
  x1 = std::min(x1, a.width), y1 = std::min(y1, a.height);
  double sum = 0.0;
  std::size_t n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      for (int c = 0; c < 3; ++c) sum += std::abs(int(a.pixel(x, y)[c]) - int(b.pixel(x, y)[c]));
      n += 3;
    }
  }
  return n == 0 ? 0.0 : sum / static_cast<double>(n);
}

}  // namespace hapvox::render
