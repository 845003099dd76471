#include "render/slice_mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "engine/check.h"

namespace hapvox::render {
namespace {

double support_of(const ToolPose& tool, const SliceMeshOptions& options) {
  return options.support_mm > 0.0 ? options.support_mm : 3.0 * tool.radius_mm;
}

// Cell size near the tool (kAdaptive): R / 8, or as coarse as max_error_mm allows.
double fine_spacing(const ToolPose& tool, const SliceMeshOptions& options, double support_mm) {
  if (options.fine_spacing_mm > 0.0) return options.fine_spacing_mm;
  const double fine = support_mm / 8.0;
  const double u_mm = tool.displacement_mm.norm();
  if (options.max_error_mm <= 0.0 || options.kernel != FfdKernel::kWendland || u_mm <= 0.0) {
    return fine;
  }
  const double within_error = support_mm * std::sqrt(options.max_error_mm / (5.0 * u_mm));
  return std::clamp(within_error, fine, support_mm / 2.0);
}

bool deforms(const ToolPose& tool) {
  return tool.radius_mm > 0.0 && tool.in_contact && tool.displacement_mm.squaredNorm() > 0.0;
}

void push_vertex(SliceMesh& mesh, const Eigen::Vector3d& rest, const Eigen::Vector3d& moved,
                 const Eigen::Vector3d& weight_gradient = Eigen::Vector3d::Zero()) {
  SliceVertex v;
  for (int a = 0; a < 3; ++a) {
    v.position[a] = static_cast<float>(moved[a]);
    v.rest[a] = static_cast<float>(rest[a]);
    v.weight_gradient[a] = static_cast<float>(weight_gradient[a]);
  }
  mesh.vertices.push_back(v);
}

// A grid of quads over breakpoints us x ws of the plane's (u, w) basis around `origin`.
void push_grid(SliceMesh& mesh, const Eigen::Vector3d& origin, const Eigen::Vector3d& eu,
               const Eigen::Vector3d& ew, const std::vector<double>& us,
               const std::vector<double>& ws, const ToolPose& tool, const SliceMeshOptions& options,
               bool displace) {
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  for (double w : ws) {
    for (double u : us) {
      const Eigen::Vector3d p = origin + u * eu + w * ew;
      if (displace) {
        push_vertex(mesh, p, ffd_displace(p, tool, options), ffd_weight_gradient(p, tool, options));
      } else {
        push_vertex(mesh, p, p);
      }
    }
  }
  const auto nu = static_cast<std::uint32_t>(us.size());
  for (std::uint32_t j = 0; j + 1 < ws.size(); ++j) {
    for (std::uint32_t i = 0; i + 1 < nu; ++i) {
      const std::uint32_t a = base + j * nu + i, b = a + 1, c = a + nu, d = c + 1;
      mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
    }
  }
}

// Breakpoints from lo to hi: the ends, plus steps of h across [c - r, c + r].
void breakpoints(double lo, double hi, double c, double r, double h, std::vector<double>& out) {
  out.clear();
  out.push_back(lo);
  const double a = std::max(lo, c - r), b = std::min(hi, c + r);
  if (a < b) {
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a) / h)));
    for (int i = 0; i <= steps; ++i) out.push_back(a + (b - a) * i / steps);
  }
  out.push_back(hi);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end(),
                        [](double x, double y) { return std::abs(x - y) < 1e-9; }),
            out.end());
}

}  // namespace

double ffd_weight(double d_mm, const SliceMeshOptions& options, double support_mm) {
  if (options.kernel == FfdKernel::kPaper) {
    return 1.0 / std::max(1.0, d_mm / options.voxel_mm);
  }
  if (d_mm >= support_mm) return 0.0;
  const double q = d_mm / support_mm;
  const double t = 1.0 - q;
  return t * t * t * t * (4.0 * q + 1.0);
}

double ffd_weight_slope(double d_mm, const SliceMeshOptions& options, double support_mm) {
  if (options.kernel == FfdKernel::kPaper) {
    return d_mm > options.voxel_mm ? -options.voxel_mm / (d_mm * d_mm) : 0.0;
  }
  if (d_mm >= support_mm) return 0.0;
  const double q = d_mm / support_mm;
  const double t = 1.0 - q;
  return -20.0 * q * t * t * t / support_mm;
}

Eigen::Vector3d ffd_weight_gradient(const Eigen::Vector3d& p_mm, const ToolPose& tool,
                                    const SliceMeshOptions& options) {
  if (!deforms(tool)) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d r = p_mm - tool.center_mm;
  const double distance = r.norm();
  if (distance <= tool.radius_mm) return Eigen::Vector3d::Zero();  // w = 1 inside the tool
  const double d = distance - tool.radius_mm;
  return ffd_weight_slope(d, options, support_of(tool, options)) * (r / distance);
}

Eigen::Vector3d ffd_displace(const Eigen::Vector3d& p_mm, const ToolPose& tool,
                             const SliceMeshOptions& options) {
  if (!deforms(tool)) return p_mm;
  const double d = std::max(0.0, (p_mm - tool.center_mm).norm() - tool.radius_mm);
  return p_mm + ffd_weight(d, options, support_of(tool, options)) * tool.displacement_mm;
}

std::vector<Eigen::Vector3d> slice_polygon(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                           const Eigen::Vector3d& n, double s) {
  std::vector<Eigen::Vector3d> points;
  // The 12 box edges: each runs along one axis from a corner with that axis at lo.
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (int k = 0; k < 4; ++k) {
      Eigen::Vector3d p0;
      p0[axis] = lo[axis];
      p0[a1] = (k & 1) ? hi[a1] : lo[a1];
      p0[a2] = (k & 2) ? hi[a2] : lo[a2];
      Eigen::Vector3d p1 = p0;
      p1[axis] = hi[axis];
      const double f0 = n.dot(p0) - s, f1 = n.dot(p1) - s;
      if ((f0 < 0.0) != (f1 < 0.0)) points.push_back(p0 + (f0 / (f0 - f1)) * (p1 - p0));
    }
  }
  if (points.size() < 3) return {};
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : points) centre += p;
  centre /= static_cast<double>(points.size());
  const Eigen::Vector3d eu = (points[0] - centre).normalized();
  const Eigen::Vector3d ew = n.cross(eu);
  std::sort(points.begin(), points.end(), [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::atan2((a - centre).dot(ew), (a - centre).dot(eu)) <
           std::atan2((b - centre).dot(ew), (b - centre).dot(eu));
  });
  return points;
}

void build_slice_mesh(const Eigen::Vector3d& frame_lo, const Eigen::Vector3d& frame_hi,
                      const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                      const Eigen::Vector3d& view_direction, const ToolPose& tool,
                      const SliceMeshOptions& options, SliceMesh& mesh) {
  HAPVOX_CHECK_GT(options.slices, 0);
  HAPVOX_CHECK_GT(options.patches, 0);
  mesh.vertices.clear();
  mesh.indices.clear();
  mesh.slice_first_index.clear();
  const Eigen::Vector3d n = view_direction.normalized();
  // In-plane basis, the same for every slice.
  const Eigen::Vector3d helper =
      std::abs(n.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d eu = n.cross(helper).normalized();
  const Eigen::Vector3d ew = n.cross(eu);
  auto extent = [&n](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double& s0, double& s1) {
    s0 = INFINITY, s1 = -INFINITY;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d c((k & 1) ? b.x() : a.x(), (k & 2) ? b.y() : a.y(),
                              (k & 4) ? b.z() : a.z());
      s0 = std::min(s0, n.dot(c));
      s1 = std::max(s1, n.dot(c));
    }
  };
  double frame_min = 0, frame_max = 0, s_min = 0, s_max = 0;
  extent(frame_lo, frame_hi, frame_min, frame_max);
  extent(lo, hi, s_min, s_max);
  const double spacing = (frame_max - frame_min) / options.slices;
  mesh.slices = 0;
  mesh.slice_spacing_mm = spacing;
  const bool displace = deforms(tool);
  const double support = support_of(tool, options);
  const double reach = tool.radius_mm + support;  // farthest point the kernel moves
  const double fine = fine_spacing(tool, options, support);
  std::vector<double> us, ws;
  // Farthest from the eye first: n points away from it, so from s_max down.
  const int first = std::max(0, static_cast<int>(std::floor((frame_max - s_max) / spacing)));
  const int last =
      std::min(options.slices - 1, static_cast<int>(std::ceil((frame_max - s_min) / spacing)));
  for (int k = first; k <= last; ++k) {
    const double s = frame_max - (k + 0.5) * spacing;
    const std::vector<Eigen::Vector3d> polygon = slice_polygon(lo, hi, n, s);
    if (polygon.empty()) continue;
    ++mesh.slices;
    mesh.slice_first_index.push_back(static_cast<std::uint32_t>(mesh.indices.size()));
    const Eigen::Vector3d origin = s * n;
    double u0 = INFINITY, u1 = -INFINITY, w0 = INFINITY, w1 = -INFINITY;
    for (const auto& p : polygon) {
      u0 = std::min(u0, p.dot(eu)), u1 = std::max(u1, p.dot(eu));
      w0 = std::min(w0, p.dot(ew)), w1 = std::max(w1, p.dot(ew));
    }
    if (options.tessellation == Tessellation::kUniform) {
      us.resize(options.patches + 1);
      ws.resize(options.patches + 1);
      for (int i = 0; i <= options.patches; ++i) {
        us[i] = u0 + (u1 - u0) * i / options.patches;
        ws[i] = w0 + (w1 - w0) * i / options.patches;
      }
      push_grid(mesh, origin, eu, ew, us, ws, tool, options, displace);
      continue;
    }
    const double plane_distance = std::abs(n.dot(tool.center_mm) - s);
    const bool reached =
        displace && (options.kernel == FfdKernel::kPaper || plane_distance < reach);
    if (!reached) {
      // The exact polygon as a fan: nothing moves here.
      const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
      for (const auto& p : polygon) push_vertex(mesh, p, p);
      for (std::uint32_t i = 1; i + 1 < polygon.size(); ++i) {
        mesh.indices.insert(mesh.indices.end(), {base, base + i, base + i + 1});
      }
      continue;
    }
    if (options.kernel == FfdKernel::kPaper) {
      // Non-compact: every vertex moves, so the grid must be fine everywhere.
      breakpoints(u0, u1, 0.5 * (u0 + u1), 0.5 * (u1 - u0), fine, us);
      breakpoints(w0, w1, 0.5 * (w0 + w1), 0.5 * (w1 - w0), fine, ws);
    } else {
      // The kernel's footprint on this plane is a disc of radius sqrt(reach^2 - dist^2).
      const double r = std::sqrt(std::max(0.0, reach * reach - plane_distance * plane_distance));
      breakpoints(u0, u1, tool.center_mm.dot(eu), r, fine, us);
      breakpoints(w0, w1, tool.center_mm.dot(ew), r, fine, ws);
    }
    push_grid(mesh, origin, eu, ew, us, ws, tool, options, true);
  }
  mesh.slice_first_index.push_back(static_cast<std::uint32_t>(mesh.indices.size()));
}

}  // namespace hapvox::render
