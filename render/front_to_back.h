#pragma once
// Front-to-back slice compositing with early termination.
//
// Back to front, every slice fragment is shaded and blended, even deep inside an opaque
// body where nothing of it can show (the clay block: 0.95 opacity per voxel, so three
// slices behind its surface a pixel is settled). Front to back ("under" blending,
//   C += (1 - A) c,  A += (1 - A) a,  premultiplied c)
// gives the same sum, and a pixel whose stored alpha has reached 1 (255 of 255) can take
// nothing more: 1 - A is 0 in the framebuffer's own arithmetic. So every few slices
// SaturationMask copies the colour buffer and writes the nearest depth where alpha is 1;
// the slices drawn after it fail the depth test there before their fragment shader runs
// (early fragment tests), which is where the time goes on llvmpipe. The image is the
// front-to-back sum: equal to back to front up to the 8-bit framebuffer's rounding.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "render/image.h"
#include "render/slice_mesh.h"

namespace hapvox::render {

/// `mesh`'s triangles, nearest slice first (the mesh holds them farthest first, each
/// slice's run starting at mesh.slice_first_index), into `indices`; `chunk_ends[c]` is
/// where chunk c's indices end, a chunk being `chunk_slices` consecutive slices.
void order_front_to_back(const SliceMesh& mesh, int chunk_slices,
                         std::vector<std::uint32_t>& indices, std::vector<std::size_t>& chunk_ends);

/// The background under what front to back left (alpha 255 - A of it), then opaque:
/// C + (1 - A) background, in the framebuffer's 8-bit steps.
void composite_background(const float (&background)[3], Image& image);

/// GL objects of the saturation pass. Needs a current context; every call on its thread.
class SaturationMask {
 public:
  SaturationMask();
  ~SaturationMask();
  SaturationMask(const SaturationMask&) = delete;
  SaturationMask& operator=(const SaturationMask&) = delete;

  /// Writes depth 0 wherever the bound framebuffer's alpha is 1 (a width x height colour
  /// buffer with a depth buffer); leaves colour, blending and the depth state as it found
  /// them for the slices (depth test LESS, no depth writes).
  void mark(int width, int height);

 private:
  unsigned program_ = 0;
  unsigned vao_ = 0;
  unsigned copy_texture_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace hapvox::render
