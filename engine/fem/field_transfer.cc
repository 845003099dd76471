#include "engine/fem/field_transfer.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "engine/check.h"

namespace hapvox::engine::fem {
namespace {

// The barycentric weights of `p` in tet t (the tet is not degenerate: validate() holds).
std::array<double, 4> weights_in(const TetMesh& mesh, int t, const Eigen::Vector3d& p) {
  const Tet& tet = mesh.tets[t];
  const Eigen::Vector3d a = mesh.rest_mm.col(tet[0]);
  const Eigen::Matrix<double, 3, 4> g = barycentric_gradients_per_mm(
      a, mesh.rest_mm.col(tet[1]), mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3]));
  std::array<double, 4> w{};
  const Eigen::Vector3d d = p - a;
  // lambda_k(p) = lambda_k(a) + g_k . (p - a), with lambda(a) = (1, 0, 0, 0).
  for (int k = 0; k < 4; ++k) w[k] = (k == 0 ? 1.0 : 0.0) + g.col(k).dot(d);
  return w;
}

double smallest(const std::array<double, 4>& w) { return *std::min_element(w.begin(), w.end()); }

// Tets binned by bounding box into a uniform grid over the mesh's box.
class TetGrid {
 public:
  explicit TetGrid(const TetMesh& mesh) {
    lo_ = mesh.rest_mm.rowwise().minCoeff();
    const Eigen::Vector3d hi = mesh.rest_mm.rowwise().maxCoeff();
    // About one tet per cell: cells of the mean tet's size.
    const double volume = std::max((hi - lo_).prod(), 1e-300);
    cell_mm_ = std::cbrt(volume / static_cast<double>(mesh.tet_count()));
    if (!(cell_mm_ > 0.0)) cell_mm_ = std::max((hi - lo_).maxCoeff(), 1.0);
    for (int a = 0; a < 3; ++a) {
      n_[a] = std::clamp(static_cast<int>(std::floor((hi(a) - lo_(a)) / cell_mm_)) + 1, 1, 512);
    }
    cells_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
    for (int t = 0; t < mesh.tet_count(); ++t) {
      Eigen::Vector3d tlo = mesh.rest_mm.col(mesh.tets[t][0]);
      Eigen::Vector3d thi = tlo;
      for (int k = 1; k < 4; ++k) {
        tlo = tlo.cwiseMin(mesh.rest_mm.col(mesh.tets[t][k]));
        thi = thi.cwiseMax(mesh.rest_mm.col(mesh.tets[t][k]));
      }
      const std::array<int, 3> c0 = cell_of(tlo);
      const std::array<int, 3> c1 = cell_of(thi);
      for (int k = c0[2]; k <= c1[2]; ++k) {
        for (int j = c0[1]; j <= c1[1]; ++j) {
          for (int i = c0[0]; i <= c1[0]; ++i) cells_[index(i, j, k)].push_back(t);
        }
      }
    }
  }

  std::array<int, 3> cell_of(const Eigen::Vector3d& p) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor((p(a) - lo_(a)) / cell_mm_);
      c[a] = static_cast<int>(std::clamp(f, 0.0, static_cast<double>(n_[a] - 1)));
    }
    return c;
  }
  const std::vector<int>& tets_at(const std::array<int, 3>& c) const {
    return cells_[index(c[0], c[1], c[2])];
  }

 private:
  std::size_t index(int i, int j, int k) const {
    const auto nx = static_cast<std::size_t>(n_[0]);
    const auto ny = static_cast<std::size_t>(n_[1]);
    return static_cast<std::size_t>(i) +
           nx * (static_cast<std::size_t>(j) + ny * static_cast<std::size_t>(k));
  }

  Eigen::Vector3d lo_;
  double cell_mm_ = 1.0;
  std::array<int, 3> n_{1, 1, 1};
  std::vector<std::vector<int>> cells_;
};

}  // namespace

std::vector<TetPoint> locate_points(const TetMesh& mesh, const Eigen::Matrix3Xd& points_mm) {
  HAPVOX_CHECK_GT(mesh.tet_count(), 0);
  const TetGrid grid(mesh);
  std::vector<TetPoint> located(static_cast<std::size_t>(points_mm.cols()));
  for (Eigen::Index p = 0; p < points_mm.cols(); ++p) {
    const Eigen::Vector3d x = points_mm.col(p);
    int best = -1;
    double best_min = -INFINITY;
    std::array<double, 4> best_w{};
    const auto consider = [&](int t) {
      const std::array<double, 4> w = weights_in(mesh, t, x);
      const double m = smallest(w);
      if (m > best_min) {
        best = t;
        best_min = m;
        best_w = w;
      }
    };
    for (const int t : grid.tets_at(grid.cell_of(x))) consider(t);
    // Outside every tet binned with it (outside the mesh, or in a gap of the grid's
    // binning): every tet decides.
    if (best_min < -1e-9) {
      for (int t = 0; t < mesh.tet_count(); ++t) consider(t);
    }
    HAPVOX_CHECK_GE(best, 0);  // a non-finite point has no tet
    located[p].tet = best;
    for (int k = 0; k < 4; ++k) located[p].vertices[k] = mesh.tets[best][k];
    located[p].weights = best_w;
  }
  return located;
}

Eigen::VectorXd interpolate_vector_field(const std::vector<TetPoint>& points,
                                         const Eigen::VectorXd& field) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(points.size()));
  for (std::size_t p = 0; p < points.size(); ++p) {
    for (int k = 0; k < 4; ++k) {
      const Eigen::Index v = points[p].vertices[k];
      HAPVOX_CHECK_LT(3 * v + 2, field.size());
      out.segment<3>(3 * static_cast<Eigen::Index>(p)) +=
          points[p].weights[k] * field.segment<3>(3 * v);
    }
  }
  return out;
}

}  // namespace hapvox::engine::fem
