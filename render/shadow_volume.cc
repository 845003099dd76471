#include "render/shadow_volume.h"

#include <algorithm>
#include <cmath>

#include "engine/check.h"
#include "render/texels.h"

namespace hapvox::render {

ShadowVolume::ShadowVolume(const Eigen::Vector3i& dims, int blur_voxels)
    : dims_(dims), bricks_(brick_counts(dims)), blur_(blur_voxels) {
  HAPVOX_CHECK(dims.minCoeff() > 0);
  HAPVOX_CHECK_GE(blur_voxels, 0);
  HAPVOX_CHECK_LE(blur_voxels, kBrickVoxels);  // the blur reaches one brick column at most
  transmittance_.assign(static_cast<std::size_t>(dims.prod()), 255);
  column_marked_.assign(static_cast<std::size_t>(bricks_.x()) * bricks_.y(), 1);
}

void ShadowVolume::mark_all() { std::fill(column_marked_.begin(), column_marked_.end(), 1); }

void ShadowVolume::mark_bricks(const std::vector<std::uint32_t>& bricks) {
  const int reach = blur_ > 0 ? 1 : 0;  // the blur carries a change into neighbour columns
  for (std::uint32_t b : bricks) {
    const int bx = static_cast<int>(b % static_cast<std::uint32_t>(bricks_.x()));
    const int by = static_cast<int>((b / static_cast<std::uint32_t>(bricks_.x())) %
                                    static_cast<std::uint32_t>(bricks_.y()));
    for (int y = std::max(by - reach, 0); y <= std::min(by + reach, bricks_.y() - 1); ++y) {
      for (int x = std::max(bx - reach, 0); x <= std::min(bx + reach, bricks_.x() - 1); ++x) {
        column_marked_[static_cast<std::size_t>(y) * bricks_.x() + x] = 1;
      }
    }
  }
}

const std::vector<std::uint32_t>& ShadowVolume::update(const std::vector<std::uint8_t>& texels,
                                                       const std::array<float, 256>& opacity) {
  HAPVOX_CHECK_EQ(texels.size(), transmittance_.size() * 4);
  changed_.clear();
  std::array<float, 256> pass{};  // 1 - a through a whole voxel
  for (int i = 0; i < 256; ++i) pass[i] = std::clamp(1.0f - opacity[i], 0.0f, 1.0f);
  for (int by = 0; by < bricks_.y(); ++by) {
    for (int bx = 0; bx < bricks_.x(); ++bx) {
      std::uint8_t& marked = column_marked_[static_cast<std::size_t>(by) * bricks_.x() + bx];
      if (!marked) continue;
      marked = 0;
      compute_column(bx, by, texels, pass);
      for (int bz = 0; bz < bricks_.z(); ++bz) {
        changed_.push_back(static_cast<std::uint32_t>((bz * bricks_.y() + by) * bricks_.x() + bx));
      }
    }
  }
  std::sort(changed_.begin(), changed_.end());
  return changed_;
}

void ShadowVolume::compute_column(int bx, int by, const std::vector<std::uint8_t>& texels,
                                  const std::array<float, 256>& pass) {
  const int x0 = bx * kBrickVoxels, x1 = std::min(x0 + kBrickVoxels, dims_.x());
  const int y0 = by * kBrickVoxels, y1 = std::min(y0 + kBrickVoxels, dims_.y());
  const int w = x1 - x0, h = y1 - y0;
  // The unblurred transmittance over the column widened by the blur (edges clamped, as the
  // texture samples them), marched down from the top, one z-plane at a time.
  const int wide_w = w + 2 * blur_, wide_h = h + 2 * blur_;
  const std::size_t plane = static_cast<std::size_t>(wide_w) * wide_h;
  raw_.resize(plane * static_cast<std::size_t>(dims_.z()));
  across_x_.assign(plane, 1.0f);  // the light reaching the current plane's top, per column
  for (int z = dims_.z() - 1; z >= 0; --z) {
    float* out = &raw_[plane * static_cast<std::size_t>(z)];
    for (int j = 0; j < wide_h; ++j) {
      const int y = std::clamp(y0 - blur_ + j, 0, dims_.y() - 1);
      const std::size_t row = (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x();
      for (int i = 0; i < wide_w; ++i) {
        const int x = std::clamp(x0 - blur_ + i, 0, dims_.x() - 1);
        const std::uint8_t density = texels[(row + x) * 4 + 3];
        float& light = across_x_[static_cast<std::size_t>(j) * wide_w + i];
        out[static_cast<std::size_t>(j) * wide_w + i] = light;
        light *= pass[density];
      }
    }
  }
  // Box blur, separable: along x into a w x wide_h plane, then along y into the texture.
  const float norm = 1.0f / static_cast<float>((2 * blur_ + 1) * (2 * blur_ + 1));
  std::vector<float>& blurred_x = across_x_;
  blurred_x.resize(static_cast<std::size_t>(w) * wide_h);
  for (int z = 0; z < dims_.z(); ++z) {
    const float* in = &raw_[plane * static_cast<std::size_t>(z)];
    for (int j = 0; j < wide_h; ++j) {
      for (int i = 0; i < w; ++i) {
        float sum = 0.0f;
        for (int k = 0; k <= 2 * blur_; ++k)
          sum += in[static_cast<std::size_t>(j) * wide_w + i + k];
        blurred_x[static_cast<std::size_t>(j) * w + i] = sum;
      }
    }
    for (int j = 0; j < h; ++j) {
      const std::size_t row = (static_cast<std::size_t>(z) * dims_.y() + y0 + j) * dims_.x();
      for (int i = 0; i < w; ++i) {
        float sum = 0.0f;
        for (int k = 0; k <= 2 * blur_; ++k) {
          sum += blurred_x[static_cast<std::size_t>(j + k) * w + i];
        }
        transmittance_[row + x0 + i] =
            static_cast<std::uint8_t>(std::lround(std::clamp(sum * norm, 0.0f, 1.0f) * 255.0f));
      }
    }
  }
}

}  // namespace hapvox::render
