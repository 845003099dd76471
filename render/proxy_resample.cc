#include "render/proxy_resample.h"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>

#include <tbb/blocked_range.h>

#include "engine/check.h"
#include "engine/parallel.h"

namespace hapvox::render {
namespace {

std::uint8_t to_byte(double value_0_255) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(value_0_255, 0.0, 255.0)));
}

}  // namespace

ProxyResampler::ProxyResampler(const DenseVolume& rest, const ResampleOptions& options)
    : options_(options),
      dims_(rest.dims),
      voxel_mm_(rest.voxel_mm),
      lo_mm_(rest.lo_mm),
      bricks_(brick_counts(rest.dims)) {
  HAPVOX_CHECK(dims_.minCoeff() > 0);
  rest_texels_.resize(rest.voxel_count() * 4);
  for (int z = 0; z < dims_.z(); ++z) {
    for (int y = 0; y < dims_.y(); ++y) {
      for (int x = 0; x < dims_.x(); ++x) {
        const std::size_t i = index(x, y, z);
        encode_texel(central_gradient(rest, x, y, z), rest.density[i], &rest_texels_[i * 4]);
      }
    }
  }
  texels_ = rest_texels_;
  state_.assign(rest.voxel_count(), 0);
  brick_now_.assign(static_cast<std::size_t>(bricks_.prod()), 0);
  brick_before_ = brick_now_;
}

void ProxyResampler::set_mesh(const engine::fem::TetMesh& mesh) {
  mesh_ = mesh;
  frame_neighbours_ = frame_neighbours(mesh_);
  vertex_rotations_.assign(static_cast<std::size_t>(mesh_.vertex_count()),
                           Eigen::Matrix3d::Identity());
  vertex_moved_.assign(static_cast<std::size_t>(mesh_.vertex_count()), 0);
  vertex_rotated_ = vertex_moved_;
}

template <class Visit>
void ProxyResampler::rasterize(const Eigen::Matrix<double, 3, 4>& corners_mm, int z_from, int z_to,
                               Visit&& visit) const {
  Eigen::Matrix3d edges;
  for (int k = 0; k < 3; ++k) edges.col(k) = corners_mm.col(k + 1) - corners_mm.col(0);
  const double det = edges.determinant();
  const double scale = edges.colwise().norm().prod();
  if (!(std::abs(det) > 1e-9 * scale)) return;  // collapsed: covers no voxel centre
  const Eigen::Matrix3d inverse = edges.inverse();
  // Voxel centres lo + (i + 0.5) voxel inside the box of the corners.
  const Eigen::Vector3d first =
      ((corners_mm.rowwise().minCoeff() - lo_mm_).cwiseQuotient(voxel_mm_).array() - 0.5).ceil();
  const Eigen::Vector3d last =
      ((corners_mm.rowwise().maxCoeff() - lo_mm_).cwiseQuotient(voxel_mm_).array() - 0.5).floor();
  Eigen::Vector3i from, to;
  for (int a = 0; a < 3; ++a) {
    from[a] = static_cast<int>(std::max(first[a], 0.0));
    to[a] = static_cast<int>(std::min(last[a], static_cast<double>(dims_[a] - 1)));
    if (!(first[a] <= static_cast<double>(dims_[a] - 1) && last[a] >= 0.0)) return;
  }
  from.z() = std::max(from.z(), z_from);
  to.z() = std::min(to.z(), z_to);
  if (from.z() > to.z()) return;     // not in this slab
  constexpr double kInside = -1e-9;  // voxel centres on a shared face belong to both tets
  // Scanlines along x: lambda is linear in x, lambda(x) = at_row + x * per_x, so each row's
  // inside interval is found first (widened by a voxel against rounding) and only its voxels
  // tested; the same voxels pass as testing the whole box would.
  Eigen::Vector4d per_x;
  per_x.tail<3>() = inverse.col(0) * voxel_mm_.x();
  per_x[0] = -per_x.tail<3>().sum();
  for (int z = from.z(); z <= to.z(); ++z) {
    for (int y = from.y(); y <= to.y(); ++y) {
      const Eigen::Vector3d p0 =
          lo_mm_ + (Eigen::Vector3d(0, y, z).array() + 0.5).matrix().cwiseProduct(voxel_mm_);
      const Eigen::Vector3d l0 = inverse * (p0 - corners_mm.col(0));
      const Eigen::Vector4d at_row(1.0 - l0.sum(), l0.x(), l0.y(), l0.z());
      double first_x = from.x(), last_x = to.x();
      for (int k = 0; k < 4; ++k) {
        if (per_x[k] > 0.0) {
          first_x = std::max(first_x, std::floor((kInside - at_row[k]) / per_x[k]) - 1.0);
        } else if (per_x[k] < 0.0) {
          last_x = std::min(last_x, std::ceil((kInside - at_row[k]) / per_x[k]) + 1.0);
        } else if (at_row[k] < kInside - 1e-9) {
          last_x = first_x - 1.0;  // never inside on this row
        }
      }
      // Both bounds lie in [from.x, to.x] once the interval is not empty (a near-zero
      // per_x can push one far outside: cast only after this check).
      if (!(first_x <= last_x)) continue;
      for (int x = static_cast<int>(first_x); x <= static_cast<int>(last_x); ++x) {
        const Eigen::Vector3d p =
            lo_mm_ + (Eigen::Vector3d(x, y, z).array() + 0.5).matrix().cwiseProduct(voxel_mm_);
        const Eigen::Vector3d l = inverse * (p - corners_mm.col(0));
        const Eigen::Vector4d lambda(1.0 - l.sum(), l.x(), l.y(), l.z());
        if (lambda.minCoeff() >= kInside) visit(x, y, z, lambda);
      }
    }
  }
}

void ProxyResampler::mark_bricks(const Eigen::Vector3d& lo_mm, const Eigen::Vector3d& hi_mm) {
  const Eigen::Vector3d lo_voxel = (lo_mm - lo_mm_).cwiseQuotient(voxel_mm_);
  const Eigen::Vector3d hi_voxel = (hi_mm - lo_mm_).cwiseQuotient(voxel_mm_);
  Eigen::Vector3i from, to;
  for (int a = 0; a < 3; ++a) {
    if (hi_voxel[a] < 0.0 || lo_voxel[a] > dims_[a]) return;
    from[a] = std::clamp(static_cast<int>(std::floor(lo_voxel[a])), 0, dims_[a] - 1) / kBrickVoxels;
    to[a] = std::clamp(static_cast<int>(std::floor(hi_voxel[a])), 0, dims_[a] - 1) / kBrickVoxels;
  }
  for (int z = from.z(); z <= to.z(); ++z) {
    for (int y = from.y(); y <= to.y(); ++y) {
      for (int x = from.x(); x <= to.x(); ++x) {
        const auto b = static_cast<std::uint32_t>((z * bricks_.y() + y) * bricks_.x() + x);
        if (!brick_now_[b]) {
          brick_now_[b] = 1;
          bricks_now_.push_back(b);
        }
      }
    }
  }
}

std::size_t ProxyResampler::resample_slab(
    int z_from, int z_to, const Eigen::Ref<const Eigen::VectorXd>& displacement_mm) {
  std::size_t resampled = 0;
  Eigen::Matrix<double, 3, 4> rest, deformed;
  const Eigen::Matrix3d* rotations[4];
  for (std::size_t m = 0; m < moved_tets_.size(); ++m) {
    const engine::fem::Tet& tet = mesh_.tets[static_cast<std::size_t>(moved_tets_[m])];
    for (int a = 0; a < 4; ++a) {
      rest.col(a) = mesh_.rest_mm.col(tet[a]);
      deformed.col(a) = rest.col(a) + displacement_mm.segment<3>(3 * tet[a]);
      rotations[a] = &vertex_rotations_[static_cast<std::size_t>(tet[a])];
    }
    // Its rest place: vacated unless a deformed tet covers it.
    rasterize(rest, z_from, z_to, [&](int x, int y, int z, const Eigen::Vector4d&) {
      std::uint8_t& state = state_[index(x, y, z)];
      if (state == 0) state = 1;
    });
    const bool inverse_transpose = options_.gradient == GradientTransform::kTetInverseTranspose;
    rasterize(deformed, z_from, z_to, [&](int x, int y, int z, const Eigen::Vector4d& lambda) {
      const std::size_t i = index(x, y, z);
      if (state_[i] == 2) return;  // the first tet in index order keeps a shared voxel
      state_[i] = 2;
      ++resampled;
      // Trilinear sample of the rest texels at X, with the texture's clamp to edge.
      const Eigen::Vector3d rest_mm = rest * lambda;
      const Eigen::Vector3d s = (rest_mm - lo_mm_).cwiseQuotient(voxel_mm_).array() - 0.5;
      const Eigen::Vector3d floor = s.array().floor();
      const Eigen::Vector3d f = s - floor;
      Eigen::Vector4d sample = Eigen::Vector4d::Zero();
      for (int corner = 0; corner < 8; ++corner) {
        int c[3];
        double w = 1.0;
        for (int a = 0; a < 3; ++a) {
          const int up = (corner >> a) & 1;
          c[a] = std::clamp(static_cast<int>(floor[a]) + up, 0, dims_[a] - 1);
          w *= up ? f[a] : 1.0 - f[a];
        }
        if (w == 0.0) continue;
        const std::uint8_t* texel = &rest_texels_[index(c[0], c[1], c[2]) * 4];
        sample += w * Eigen::Vector4d(texel[0], texel[1], texel[2], texel[3]);
      }
      const Eigen::Vector3d gradient = sample.head<3>() / 127.5 - Eigen::Vector3d::Ones();
      Eigen::Vector3d turned;
      if (inverse_transpose) {
        // F^-T g, at the length g had: the shader reads the length as "shaded or not".
        turned = tet_inverse_transposes_[m] * gradient;
        const double norm = turned.norm();
        if (norm > 0.0) turned *= gradient.norm() / norm;
      } else {
        Eigen::Matrix3d blend = lambda[0] * *rotations[0];
        for (int a = 1; a < 4; ++a) blend += lambda[a] * *rotations[a];
        turned = blend * gradient;
      }
      std::uint8_t* out = &texels_[i * 4];
      for (int a = 0; a < 3; ++a) out[a] = to_byte(127.5 * (turned[a] + 1.0));
      out[3] = to_byte(sample[3]);
    });
  }
  return resampled;
}

ResampleStats ProxyResampler::update(const Eigen::Ref<const Eigen::VectorXd>& displacement_mm) {
  const auto t0 = std::chrono::steady_clock::now();
  const int vertices = mesh_.vertex_count();
  HAPVOX_CHECK_GT(vertices, 0);
  HAPVOX_CHECK_EQ(displacement_mm.size(), 3 * static_cast<Eigen::Index>(vertices));
  ResampleStats stats;
  const double threshold_mm = options_.motion_threshold_voxels * voxel_mm_.minCoeff();
  for (int v = 0; v < vertices; ++v) {
    vertex_moved_[static_cast<std::size_t>(v)] =
        displacement_mm.segment<3>(3 * v).norm() > threshold_mm ? 1 : 0;
  }
  // Serially: the moved tets, the bricks they touch, and the rotations (or F^-T) they use.
  std::fill(vertex_rotated_.begin(), vertex_rotated_.end(), 0);
  moved_tets_.clear();
  tet_inverse_transposes_.clear();
  for (std::int32_t t = 0; t < mesh_.tet_count(); ++t) {
    const engine::fem::Tet& tet = mesh_.tets[static_cast<std::size_t>(t)];
    bool moved = false;
    for (int a = 0; a < 4; ++a) moved = moved || vertex_moved_[static_cast<std::size_t>(tet[a])];
    if (!moved) continue;
    moved_tets_.push_back(t);
    Eigen::Matrix<double, 3, 4> rest, deformed;
    for (int a = 0; a < 4; ++a) {
      rest.col(a) = mesh_.rest_mm.col(tet[a]);
      deformed.col(a) = rest.col(a) + displacement_mm.segment<3>(3 * tet[a]);
    }
    mark_bricks(rest.rowwise().minCoeff(), rest.rowwise().maxCoeff());
    mark_bricks(deformed.rowwise().minCoeff(), deformed.rowwise().maxCoeff());
    if (options_.gradient == GradientTransform::kTetInverseTranspose) {
      tet_inverse_transposes_.push_back(tet_inverse_transpose(mesh_, t, displacement_mm));
      continue;
    }
    for (int a = 0; a < 4; ++a) {  // once per update, for the vertices of moved tets only
      const auto k = static_cast<std::size_t>(tet[a]);
      if (vertex_rotated_[k]) continue;
      vertex_rotations_[k] = vertex_rotation(mesh_, frame_neighbours_[k], tet[a], displacement_mm);
      vertex_rotated_[k] = 1;
    }
  }
  stats.moved_tets = moved_tets_.size();
  // In parallel: slabs of one brick layer each, every voxel written by its slab alone, the
  // tets taken in index order within each, so the result does not depend on the threads.
  stats.resampled_voxels = engine::parallel_reduce(
      tbb::blocked_range<int>(0, bricks_.z()), std::size_t{0},
      [&](const tbb::blocked_range<int>& layers, std::size_t count) {
        for (int layer = layers.begin(); layer != layers.end(); ++layer) {
          count +=
              resample_slab(layer * kBrickVoxels,
                            std::min((layer + 1) * kBrickVoxels, dims_.z()) - 1, displacement_mm);
        }
        return count;
      },
      std::plus<>());

  // Settle the bricks touched now (in parallel, each brick its own), restore those touched
  // only before.
  stats.vacated_voxels = engine::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, bricks_now_.size()), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& range, std::size_t vacated) {
        for (std::size_t k = range.begin(); k != range.end(); ++k) {
          Eigen::Vector3i lo, hi;
          brick_voxel_box(dims_, bricks_now_[k], lo, hi);
          for (int z = lo.z(); z < hi.z(); ++z) {
            for (int y = lo.y(); y < hi.y(); ++y) {
              for (int x = lo.x(); x < hi.x(); ++x) {
                const std::size_t i = index(x, y, z);
                if (state_[i] == 0) {
                  std::copy_n(&rest_texels_[i * 4], 4, &texels_[i * 4]);
                } else if (state_[i] == 1) {
                  static constexpr std::uint8_t kEmpty[4] = {128, 128, 128, 0};
                  std::copy_n(kEmpty, 4, &texels_[i * 4]);
                  ++vacated;
                }
                state_[i] = 0;
              }
            }
          }
        }
        return vacated;
      },
      std::plus<>());
  changed_.assign(bricks_now_.begin(), bricks_now_.end());
  for (std::uint32_t b : bricks_before_) {
    brick_before_[b] = 0;
    if (brick_now_[b]) continue;
    Eigen::Vector3i lo, hi;
    brick_voxel_box(dims_, b, lo, hi);
    for (int z = lo.z(); z < hi.z(); ++z) {
      for (int y = lo.y(); y < hi.y(); ++y) {
        const std::size_t i = index(lo.x(), y, z);
        std::copy_n(&rest_texels_[i * 4], 4 * static_cast<std::size_t>(hi.x() - lo.x()),
                    &texels_[i * 4]);
      }
    }
    changed_.push_back(b);
  }
  std::sort(changed_.begin(), changed_.end());
  // The bricks touched now are next update's "before".
  std::swap(bricks_before_, bricks_now_);
  std::swap(brick_before_, brick_now_);
  bricks_now_.clear();
  stats.changed_bricks = changed_.size();
  stats.ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return stats;
}

}  // namespace hapvox::render
