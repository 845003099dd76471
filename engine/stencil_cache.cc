#include "engine/stencil_cache.h"

#include <cmath>
#include <cstring>

namespace hapvox::engine {
namespace {

// The two vectorisable passes, built for AVX2 and for the baseline, picked at load time.
// "avx2" leaves out FMA: a fused multiply-add would round differently from the scalar
// reads these must equal.
// Not under ThreadSanitizer: the clones' resolver runs while the program is relocated,
// before TSan's runtime starts, and an instrumented resolver crashes it.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_THREAD__)
#define HAPVOX_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define HAPVOX_VECTOR_CLONES
#endif

// The passes run over whole blocks of kBlock points (the arrays are padded to it), in
// GCC's vector types: one AVX register a block in the avx2 clone, two SSE registers in
// the baseline one. (Plain loops are not vectorised at -O2.)
constexpr std::size_t kBlock = StencilCache::kBlock;
// The helpers return through out-parameters: an AVX vector returned by value would have
// another calling convention in each clone.
typedef float Floats __attribute__((vector_size(kBlock * sizeof(float))));
typedef int Ints __attribute__((vector_size(kBlock * sizeof(int))));

template <typename Vector, typename T>
void load(const T* p, Vector& v) {
  std::memcpy(&v, p, sizeof v);
}
template <typename Vector, typename T>
void store(T* p, const Vector& v) {
  std::memcpy(p, &v, sizeof v);
}

// floor(q) for |q| < 2^31: truncate, then step down where that rounded up. It equals
// std::floor but for q = -0 (it gives +0, and the fraction q - floor(q) -0 for +0: the
// interpolation then adds -0 where the scalar path adds +0, the same density).
void floor_blocks(const Floats& q, Floats& floor_q) {
  const Floats t = __builtin_convertvector(__builtin_convertvector(q, Ints), Floats);
  floor_q = t + __builtin_convertvector(t > q, Floats);  // true is -1
}

struct LocatePass {
  float cx, cy, cz;
  const float *ox, *oy, *oz;
  int *ix, *iy, *iz;
  float *fx, *fy, *fz;
  int* moved;
};

HAPVOX_VECTOR_CLONES
void locate(const LocatePass& p, std::size_t n) {
  const Floats zero = {};
  const Floats cx = zero + p.cx, cy = zero + p.cy, cz = zero + p.cz;
  for (std::size_t k = 0; k < n; k += kBlock) {
    // locate_stencil (engine/trilinear.h), term by term.
    Floats ox, oy, oz, x0, y0, z0;
    load(p.ox + k, ox);
    load(p.oy + k, oy);
    load(p.oz + k, oz);
    const Floats qx = cx + ox, qy = cy + oy, qz = cz + oz;
    floor_blocks(qx, x0);
    floor_blocks(qy, y0);
    floor_blocks(qz, z0);
    store(p.fx + k, qx - x0);
    store(p.fy + k, qy - y0);
    store(p.fz + k, qz - z0);
    const Ints jx = __builtin_convertvector(x0, Ints);
    const Ints jy = __builtin_convertvector(y0, Ints);
    const Ints jz = __builtin_convertvector(z0, Ints);
    Ints ix, iy, iz;
    load(p.ix + k, ix);
    load(p.iy + k, iy);
    load(p.iz + k, iz);
    const Ints moved = (jx != ix) | (jy != iy) | (jz != iz);
    store(p.moved + k, moved);
    store(p.ix + k, jx);
    store(p.iy + k, jy);
    store(p.iz + k, jz);
  }
}

struct InterpolatePass {
  const float* v[8];
  const float *fx, *fy, *fz;
  float* rho;
};

HAPVOX_VECTOR_CLONES
void interpolate(const InterpolatePass& p, std::size_t n) {
  for (std::size_t k = 0; k < n; k += kBlock) {
    Floats fx, fy, fz, v[8];
    load(p.fx + k, fx);
    load(p.fy + k, fy);
    load(p.fz + k, fz);
    // Written out: a loop here is not unrolled at -O2, and copies through the stack.
    load(p.v[0] + k, v[0]);
    load(p.v[1] + k, v[1]);
    load(p.v[2] + k, v[2]);
    load(p.v[3] + k, v[3]);
    load(p.v[4] + k, v[4]);
    load(p.v[5] + k, v[5]);
    load(p.v[6] + k, v[6]);
    load(p.v[7] + k, v[7]);
    Floats rho;
    mix_trilinear(v, fx, fy, fz, rho);
    store(p.rho + k, rho);
  }
}

}  // namespace

void StencilCache::reserve(const std::vector<Eigen::Vector3f>& offsets) {
  points_ = offsets.size();
  // Padded to whole blocks with points at the centre, whose densities are never read.
  const std::size_t n = (points_ + kBlock - 1) / kBlock * kBlock;
  for (int a = 0; a < 3; ++a) {
    offset_[a].assign(n, 0.0f);
    for (std::size_t k = 0; k < points_; ++k) offset_[a][k] = offsets[k][a];
    first_voxel_[a].assign(n, kStale);
    fraction_[a].assign(n, 0.0f);
  }
  for (auto& corner : corner_) corner.assign(n, 0.0f);
  moved_.assign(n, 1);
  densities_.assign(n, 0.0f);
}

void StencilCache::invalidate() {
  // No stencil starts at x = INT_MIN (LeafWindow::cover refuses such centres).
  for (int& x : first_voxel_[0]) x = kStale;
}

const float* StencilCache::sample(const Eigen::Vector3f& c, const LeafWindow& window) {
  const std::size_t n = moved_.size();
  locate({c.x(), c.y(), c.z(), offset_[0].data(), offset_[1].data(), offset_[2].data(),
          first_voxel_[0].data(), first_voxel_[1].data(), first_voxel_[2].data(),
          fraction_[0].data(), fraction_[1].data(), fraction_[2].data(), moved_.data()},
         n);
  for (std::size_t k = 0; k < n; ++k) {
    if (moved_[k] == 0) continue;
    float v[8];
    window.stencil(first_voxel_[0][k], first_voxel_[1][k], first_voxel_[2][k], v);
    for (int j = 0; j < 8; ++j) corner_[j][k] = v[j];
    ++refills_;
  }
  InterpolatePass pass{
      {}, fraction_[0].data(), fraction_[1].data(), fraction_[2].data(), densities_.data()};
  for (int j = 0; j < 8; ++j) pass.v[j] = corner_[j].data();
  interpolate(pass, n);
  return densities_.data();
}

}  // namespace hapvox::engine
