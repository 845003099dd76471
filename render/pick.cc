#include "render/pick.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hapvox::render {

double density_at(const DenseVolume& volume, const Eigen::Vector3d& p_mm) {
  // Continuous voxel coordinates with voxel centres at integers.
  const Eigen::Vector3d u = (p_mm - volume.lo_mm).cwiseQuotient(volume.voxel_mm).array() - 0.5;
  const Eigen::Vector3d f = u.array().floor();
  const int x = static_cast<int>(f.x()), y = static_cast<int>(f.y()), z = static_cast<int>(f.z());
  const Eigen::Vector3d w = u - f;
  double sum = 0.0;
  for (int dz = 0; dz < 2; ++dz) {
    for (int dy = 0; dy < 2; ++dy) {
      for (int dx = 0; dx < 2; ++dx) {
        const double weight =
            (dx ? w.x() : 1.0 - w.x()) * (dy ? w.y() : 1.0 - w.y()) * (dz ? w.z() : 1.0 - w.z());
        sum += weight * volume.at_clamped(x + dx, y + dy, z + dz);
      }
    }
  }
  return sum;
}

std::optional<Eigen::Vector3d> pick_surface(const DenseVolume& volume,
                                            const Eigen::Vector3d& origin_mm,
                                            const Eigen::Vector3d& direction, double threshold) {
  if (volume.voxel_count() == 0 || !direction.allFinite() || direction.norm() == 0.0) {
    return std::nullopt;
  }
  const Eigen::Vector3d d = direction.normalized();
  // The ray's stretch inside the box (slabs).
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (origin_mm[a] < volume.lo_mm[a] || origin_mm[a] > volume.hi_mm[a]) return std::nullopt;
      continue;
    }
    double near = (volume.lo_mm[a] - origin_mm[a]) / d[a];
    double far = (volume.hi_mm[a] - origin_mm[a]) / d[a];
    if (near > far) std::swap(near, far);
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
  }
  if (!(t0 <= t1)) return std::nullopt;
  const double step = 0.25 * volume.voxel_mm.minCoeff();
  double before = t0;
  for (double t = t0;; t = std::min(t + step, t1)) {
    if (density_at(volume, origin_mm + t * d) >= threshold) {
      if (t == t0) return origin_mm + t * d;  // inside from the box's face on
      double lo = before, hi = t;             // below the threshold at lo, at or above at hi
      while (hi - lo > 1e-6 * step) {
        const double mid = 0.5 * (lo + hi);
        (density_at(volume, origin_mm + mid * d) >= threshold ? hi : lo) = mid;
      }
      return origin_mm + hi * d;
    }
    if (t >= t1) return std::nullopt;
    before = t;
  }
}

Eigen::Vector3d surface_normal(const DenseVolume& volume, const Eigen::Vector3d& p_mm) {
  Eigen::Vector3d gradient;
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3d h = Eigen::Vector3d::Zero();
    h[a] = 0.5 * volume.voxel_mm[a];
    gradient[a] = (density_at(volume, p_mm + h) - density_at(volume, p_mm - h)) / (2.0 * h[a]);
  }
  const double length = gradient.norm();
  return length > 0.0 ? Eigen::Vector3d(-gradient / length) : Eigen::Vector3d::Zero();
}

Eigen::Vector3d clear_of_material(const DenseVolume& volume, const Eigen::Vector3d& start_mm,
                                  const Eigen::Vector3d& direction, double radius_mm,
                                  double threshold, double max_distance_mm) {
  if (!direction.allFinite() || direction.norm() == 0.0) return start_mm;
  const Eigen::Vector3d unit = direction.normalized();
  auto clear = [&](const Eigen::Vector3d& centre) {
    if (density_at(volume, centre) >= threshold) return false;
    for (int x = -1; x <= 1; ++x) {
      for (int y = -1; y <= 1; ++y) {
        for (int z = -1; z <= 1; ++z) {
          if (x == 0 && y == 0 && z == 0) continue;
          const Eigen::Vector3d on_sphere =
              centre + radius_mm * Eigen::Vector3d(x, y, z).normalized();
          if (density_at(volume, on_sphere) >= threshold) return false;
        }
      }
    }
    return true;
  };
  const double step = 0.25 * volume.voxel_mm.minCoeff();
  Eigen::Vector3d p = start_mm;
  for (double t = 0.0; t <= max_distance_mm; t += step) {
    p = start_mm + t * unit;
    if (clear(p)) return p;
  }
  return p;
}

}  // namespace hapvox::render
