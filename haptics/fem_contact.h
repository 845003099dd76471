#pragma once
// The 1 kHz side of the proxy-FEM haptics (Nakao's push, pull and grab; docs/physics.md,
// "Haptics from the proxy mesh"): what the FEM thread publishes for the force thread, and
// the two contact solves the force thread runs on it every tick. Fixed-capacity storage:
// neither solve allocates, locks or throws.
//
// The FEM thread condenses the stiffness onto a few vertices near the tool: their
// compliance W = H K^-1 H^T (3x3 blocks, mm/N) and where they sit with no contact force
// (base_mm). Exact for linear statics, a linearisation about the current state for the
// co-rotational mode. The force thread then needs no K:
//
//   press  the tool is a sphere of radius r; vertex i touches it along n_i, from the tool
//          proxy's last position to the vertex's base position (the sphere's centre is the
//          proxy, not the device, which the coupling lets sink deeper). Its contact force lambda_i
//          n_i >= 0 (no adhesion), frictionless. With a virtual coupling of stiffness k_c between
//          the device position p_d and the tool proxy p, the proxy's equilibrium gives p = p_d -
//          sum_j lambda_j n_j / k_c, and the gaps form the linear complementarity problem  w = q +
//          M lambda >= 0, lambda >= 0, w . lambda = 0  with
//            q_i  = n_i . (base_i - p_d) - r        (negative: the device penetrates)
//            M_ij = n_i . W_ij n_j + n_i . n_j / k_c (symmetric positive definite),
//          solved exactly by principal pivoting (Murty's least-index rule). The device
//          feels k_c (p - p_d) = -sum lambda_i n_i.
//   grab   the captured vertices follow the proxy: u_c = (p - anchor) for each. Their total
//          force is F(d) = F_cur + K_g (d - d_cur), K_g = sum of the blocks of W^-1, and the
//          coupling gives (k_c I + K_g) p = k_c p_d - F_cur + K_g (anchor + d_cur).

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "haptics/session.h"

namespace hapvox::haptics {

/// The most vertices a contact snapshot holds (press candidates or grabbed vertices).
inline constexpr int kMaxContactVertices = 32;

/// What the FEM thread publishes to the force thread (a value type of fixed size).
struct ContactSnapshot {
  static constexpr int kMaxDofs = 3 * kMaxContactVertices;
  using Compliance = Eigen::Matrix<double, kMaxDofs, kMaxDofs>;

  int count = 0;  // vertices in use
  std::array<std::int32_t, kMaxContactVertices> vertices{};
  std::array<Vec3d, kMaxContactVertices> base_mm{};  // press: position with no contact force
  Compliance w_mm_per_n = Compliance::Zero();        // W; rows/columns 3i + axis

  // Grab (count = the captured vertices).
  bool grabbing = false;
  Vec3d anchor_mm = Vec3d::Zero();  // proxy position at the capture
  Eigen::Matrix3d grab_stiffness_n_per_mm = Eigen::Matrix3d::Zero();  // K_g
  Vec3d grab_offset_mm = Vec3d::Zero();                               // d_cur
  Vec3d grab_force_n = Vec3d::Zero();  // F_cur: on the vertices at d_cur

  std::uint64_t fem_step = 0;  // the FEM step that made it
};

/// The result of one contact solve.
struct ContactSolve {
  Vec3d force_n = Vec3d::Zero();  // on the device (the coupling spring's pull)
  Vec3d proxy_mm = Vec3d::Zero();
  int active = 0;         // press: vertices in contact; grab: captured vertices
  bool converged = true;  // press: the pivoting finished within its bound
  /// Press: each snapshot vertex's contact force magnitude (N), 0 when not in contact.
  std::array<double, kMaxContactVertices> lambda_n{};
  /// Press: each snapshot vertex's contact normal.
  std::array<Vec3d, kMaxContactVertices> normal{};
};

/// Working storage of the press solve (fixed size, reused tick to tick). The active set of
/// the last solve is its warm start, which changes the work, never the solution.
struct PressScratch {
  using Square = Eigen::Matrix<double, kMaxContactVertices, kMaxContactVertices>;
  using Column = Eigen::Matrix<double, kMaxContactVertices, 1>;
  Square m = Square::Zero();
  Column q = Column::Zero();
  std::array<bool, kMaxContactVertices> active{};
  std::uint64_t snapshot_step = ~std::uint64_t{0};  // whose vertices `active` refers to
};

/// The press solve at device position `device_mm` with a tool sphere of `radius_mm` and a
/// coupling of `coupling_n_per_mm` (> 0); the normals point from `proxy_hint_mm` (the proxy
/// of the last tick; the device position on the first) to the base positions. A vertex
/// whose base position coincides with the hint has no normal and is left out.
ContactSolve solve_press(const ContactSnapshot& snapshot, const Vec3d& device_mm,
                         const Vec3d& proxy_hint_mm, double radius_mm, double coupling_n_per_mm,
                         PressScratch& scratch) noexcept;

/// The grab solve at device position `device_mm` (no force without a capture).
ContactSolve solve_grab(const ContactSnapshot& snapshot, const Vec3d& device_mm,
                        double coupling_n_per_mm) noexcept;

}  // namespace hapvox::haptics
