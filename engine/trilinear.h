#pragma once
// The force path's trilinear read, in one place: where a point's 2x2x2 stencil starts and
// how its eight values are mixed (z, then y, then x). Every reader of the density on the
// force path (the accessor fallback, LeafWindow, StencilCache's vector passes) does this
// arithmetic term by term, so that their densities are the same bits.

#include <Eigen/Core>
#include <cmath>

namespace hapvox::engine {

/// A point's stencil: its first voxel (ix, iy, iz) and the point's place inside it.
struct StencilPoint {
  int ix, iy, iz;
  float fx, fy, fz;
};

inline StencilPoint locate_stencil(const Eigen::Vector3f& q) {
  const float x0 = std::floor(q.x());
  const float y0 = std::floor(q.y());
  const float z0 = std::floor(q.z());
  return {static_cast<int>(x0), static_cast<int>(y0), static_cast<int>(z0),
          q.x() - x0,           q.y() - y0,           q.z() - z0};
}

/// v: v000, v001, v010, v011, v100, v101, v110, v111 (x slowest, z fastest). T: float,
/// or a vector of floats (StencilCache's blocks of points, lane by lane; the result is an
/// out-parameter because returning an AVX vector from a function built for both AVX and
/// the baseline would change its calling convention).
template <typename T>
inline void mix_trilinear(const T* v, const T& fx, const T& fy, const T& fz, T& out) {
  const T a00 = v[0] + fz * (v[1] - v[0]);
  const T a01 = v[2] + fz * (v[3] - v[2]);
  const T a10 = v[4] + fz * (v[5] - v[4]);
  const T a11 = v[6] + fz * (v[7] - v[6]);
  const T b0 = a00 + fy * (a01 - a00);
  const T b1 = a10 + fy * (a11 - a10);
  out = b0 + fx * (b1 - b0);
}

inline float trilinear(const float* v, float fx, float fy, float fz) {
  float density;
  mix_trilinear(v, fx, fy, fz, density);
  return density;
}

}  // namespace hapvox::engine
