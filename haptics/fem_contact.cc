#include "haptics/fem_contact.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>

namespace hapvox::haptics {
namespace {

constexpr int kMax = kMaxContactVertices;
using SubMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMax, kMax>;
using SubVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMax, 1>;

// lambda_A = -M_AA^-1 q_A, zero elsewhere. False when M_AA is not positive definite.
bool solve_active(const PressScratch& s, int n, PressScratch::Column& lambda) {
  std::array<int, kMax> index{};
  int k = 0;
  for (int i = 0; i < n; ++i) {
    if (s.active[i]) index[k++] = i;
  }
  lambda.setZero();
  if (k == 0) return true;
  SubMatrix m(k, k);
  SubVector rhs(k);
  for (int a = 0; a < k; ++a) {
    rhs(a) = -s.q(index[a]);
    for (int b = 0; b < k; ++b) m(a, b) = s.m(index[a], index[b]);
  }
  const Eigen::LLT<SubMatrix> llt(m);
  if (llt.info() != Eigen::Success) return false;
  const SubVector x = llt.solve(rhs);
  for (int a = 0; a < k; ++a) lambda(index[a]) = x(a);
  return true;
}

}  // namespace

ContactSolve solve_press(const ContactSnapshot& snapshot, const Vec3d& device_mm,
                         const Vec3d& proxy_hint_mm, double radius_mm, double coupling_n_per_mm,
                         PressScratch& s) noexcept {
  ContactSolve out;
  out.proxy_mm = device_mm;
  const int n = snapshot.count;
  if (snapshot.fem_step != s.snapshot_step) {
    s.active.fill(false);  // a new vertex set: no warm start
    s.snapshot_step = snapshot.fem_step;
  }
  // Normals and gaps; a vertex without a normal gets a gap that keeps it out of contact.
  double scale = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vec3d r = snapshot.base_mm[i] - proxy_hint_mm;
    const double distance = r.norm();
    out.normal[i] = distance > 0.0 ? Vec3d(r / distance) : Vec3d::Zero();
    s.q(i) = distance > 0.0 ? out.normal[i].dot(snapshot.base_mm[i] - device_mm) - radius_mm : 1.0;
    if (distance == 0.0) s.active[i] = false;
    scale = std::max(scale, std::abs(s.q(i)));
  }
  const double inverse_coupling = 1.0 / coupling_n_per_mm;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j <= i; ++j) {
      const double w =
          out.normal[i].dot(snapshot.w_mm_per_n.block<3, 3>(3 * i, 3 * j) * out.normal[j]) +
          out.normal[i].dot(out.normal[j]) * inverse_coupling;
      s.m(i, j) = w;
      s.m(j, i) = w;
    }
  }
  // Principal pivoting with Murty's least-index rule: finite for a P-matrix (M is SPD).
  const double tolerance = 1e-12 * std::max(scale, 1e-9);
  PressScratch::Column lambda = PressScratch::Column::Zero();
  PressScratch::Column w = PressScratch::Column::Zero();
  bool converged = false;
  for (int iteration = 0; iteration < 8 * kMax + 8; ++iteration) {
    if (!solve_active(s, n, lambda)) break;
    w.head(n) = s.q.head(n) + s.m.topLeftCorner(n, n) * lambda.head(n);
    int violated = -1;
    for (int i = 0; i < n && violated < 0; ++i) {
      const double lambda_tolerance =
          tolerance * std::max(1.0, s.m(i, i) > 0 ? 1.0 / s.m(i, i) : 1.0);
      if (s.active[i] ? lambda(i) < -lambda_tolerance : w(i) < -tolerance) violated = i;
    }
    if (violated < 0) {
      converged = true;
      break;
    }
    s.active[violated] = !s.active[violated];
  }
  out.converged = converged;
  if (!converged) {
    out.proxy_mm = proxy_hint_mm;
    s.active.fill(false);
    return out;  // no force rather than a wrong one; the caller counts it
  }
  Vec3d on_vertices = Vec3d::Zero();
  for (int i = 0; i < n; ++i) {
    out.lambda_n[i] = s.active[i] ? std::max(lambda(i), 0.0) : 0.0;
    if (out.lambda_n[i] > 0.0) ++out.active;
    on_vertices += out.lambda_n[i] * out.normal[i];
  }
  out.force_n = -on_vertices;
  out.proxy_mm = device_mm + out.force_n * inverse_coupling;
  return out;
}

ContactSolve solve_grab(const ContactSnapshot& snapshot, const Vec3d& device_mm,
                        double coupling_n_per_mm) noexcept {
  ContactSolve out;
  out.proxy_mm = device_mm;
  if (!snapshot.grabbing || snapshot.count == 0) return out;
  const Eigen::Matrix3d& k_g = snapshot.grab_stiffness_n_per_mm;
  const Eigen::Matrix3d a = coupling_n_per_mm * Eigen::Matrix3d::Identity() + k_g;
  const Vec3d rhs = coupling_n_per_mm * device_mm - snapshot.grab_force_n +
                    k_g * (snapshot.anchor_mm + snapshot.grab_offset_mm);
  out.proxy_mm = a.partialPivLu().solve(rhs);
  const Vec3d on_vertices =
      snapshot.grab_force_n + k_g * (out.proxy_mm - snapshot.anchor_mm - snapshot.grab_offset_mm);
  out.force_n = -on_vertices;
  out.active = snapshot.count;
  return out;
}

}  // namespace hapvox::haptics
