#include "engine/io/generators.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <system_error>

#include "engine/errors.h"
#include "engine/io/grid_build.h"
#include "engine/io/text.h"

namespace hapvox::engine::io {

namespace {

// Box centre in index space: voxel faces span [-0.5, n - 0.5].
double box_centre(int n) { return 0.5 * (n - 1); }

DensityField field_of(openvdb::FloatGrid::Ptr grid, const GeneratorOptions& opt) {
  return DensityField(grid, Vec3d::Constant(opt.voxel_mm), Vec3d::Zero(),
                      Vec3i::Constant(opt.dims));
}

DensityField make_block(const GeneratorOptions& opt) {
  const int n = opt.dims;
  auto grid = openvdb::FloatGrid::create(0.0f);
  // k < fill * n, with a little slack so fill=0.3, n=10 gives 3 layers, not 4.
  const int layers = std::min(n, static_cast<int>(std::ceil(opt.fill * n - 1e-9)));
  if (layers > 0) {
    grid->tree().fill(
        openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(n - 1, n - 1, layers - 1)), 1.0f,
        true);
    // The force code walks leaves; dense tiles would hide the voxels from it.
    grid->tree().voxelizeActiveTiles();
  }
  return field_of(grid, opt);
}

// The share of the unit cube centred at the origin where n.e <= s (n a unit vector): the
// volume under a plane cutting the box [0,1]^3 by inclusion-exclusion over its corners.
double cube_share_below(const Vec3d& n, double s) {
  const Vec3d a = n.cwiseAbs().cwiseMax(1e-3);  // a face along the grid, nearly: no 0/0
  const double t = s + 0.5 * a.sum();
  double sum = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    double height = 0.0;
    int bits = 0;
    for (int i = 0; i < 3; ++i) {
      if ((corner >> i) & 1) {
        height += a[i];
        ++bits;
      }
    }
    const double u = std::max(0.0, t - height);
    sum += (bits % 2 == 0 ? 1.0 : -1.0) * u * u * u;
  }
  return std::clamp(sum / (6.0 * a.prod()), 0.0, 1.0);
}

DensityField make_sphere(const GeneratorOptions& opt) {
  const int n = opt.dims;
  const double c = box_centre(n);
  const double r_mm = opt.radius_mm > 0.0 ? opt.radius_mm : 0.35 * n * opt.voxel_mm;
  const double r = r_mm / opt.voxel_mm;
  const double r2 = r * r;
  auto grid = build_grid(Vec3i::Constant(n), [&](int x, int y, int z) {
    const double dx = x - c, dy = y - c, dz = z - c;
    const double q2 = dx * dx + dy * dy + dz * dz;
    const double q = std::sqrt(q2);
    if (opt.binary_edge || q < 1.0) return q2 <= r2 ? 1.0f : 0.0f;  // (a sphere of a voxel)
    if (q <= r - 1.0) return 1.0f;
    if (q >= r + 1.0) return 0.0f;
    // The share of the voxel inside the sphere, as a scan's edge voxels hold: the voxel
    // point c + e is inside where n.e + |e_t|^2 / 2q <= r - q (n the outward normal, e_t
    // e's part across it), and |e_t|^2 averages 1/6 over a cube.
    const Vec3d normal = Vec3d(dx, dy, dz) / q;
    return static_cast<float>(cube_share_below(normal, r - q - 1.0 / (12.0 * q)));
  });
  return field_of(grid, opt);
}

// Centres on a regular tetrahedron around the box centre. With radius 0.18 n and centre
// distance 0.3 n, neighbours are 0.49 n apart (> 2r = 0.36 n) and every sphere stays 0.15 n
// inside the box faces.
DensityField make_four_spheres(const GeneratorOptions& opt) {
  const int n = opt.dims;
  const double c = box_centre(n);
  const double r = 0.18 * n;
  const double d = 0.3 * n / std::sqrt(3.0);  // per-axis offset of each centre
  const std::array<Vec3d, 4> centres = {Vec3d(c + d, c + d, c + d), Vec3d(c + d, c - d, c - d),
                                        Vec3d(c - d, c + d, c - d), Vec3d(c - d, c - d, c + d)};
  const std::array<float, 4> densities = {0.4f, 0.6f, 0.8f, 1.0f};
  auto grid = build_grid(Vec3i::Constant(n), [&](int x, int y, int z) {
    const Vec3d p(x, y, z);
    for (std::size_t i = 0; i < centres.size(); ++i) {
      if ((p - centres[i]).squaredNorm() <= r * r) return densities[i];
    }
    return 0.0f;
  });
  return field_of(grid, opt);
}

}  // namespace

const std::vector<VolumeGenerator>& volume_generators() {
  static const std::vector<VolumeGenerator> generators = {
      {"block", "clay block: the lower fill (default 0.5) of a dims^3 box", {"fill"}, make_block},
      {"sphere",
       "solid sphere centred in a dims^3 box, its edge voxels holding their share of it "
       "(edge=binary: 1 inside, 0 outside)",
       {"radius_mm", "edge"},
       make_sphere},
      {"four-spheres",
       "Nakao's phantom: spheres of densities 0.4/0.6/0.8/1.0",
       {},
       make_four_spheres},
  };
  return generators;
}

namespace {

namespace fs = std::filesystem;

const VolumeGenerator* find_generator(const std::string& name) {
  for (const VolumeGenerator& g : volume_generators()) {
    if (name == g.name) return &g;
  }
  return nullptr;
}

GeneratorOptions parse_generator(const std::string& spec, std::string* name) {
  const std::string source = "generator " + spec;
  const auto colon = spec.find(':');
  *name = spec.substr(0, colon);
  const VolumeGenerator* generator = find_generator(*name);
  if (generator == nullptr) {
    std::string names;
    const auto& all = volume_generators();
    for (std::size_t i = 0; i < all.size(); ++i) {
      names += std::string(i == 0 ? "" : i + 1 == all.size() ? " or " : ", ") + all[i].name;
    }
    throw InputError(source, "unknown generator '" + *name + "' (expected " + names + ")");
  }
  std::vector<std::string> allowed = {"dims", "voxel_mm"};
  allowed.insert(allowed.end(), generator->options.begin(), generator->options.end());
  GeneratorOptions opt;
  if (colon == std::string::npos) return opt;
  std::map<std::string, std::string> seen;
  std::size_t start = colon + 1;
  while (true) {
    const auto comma = spec.find(',', start);
    const std::string item = spec.substr(start, comma - start);
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InputError(source, "expected key=value, got '" + item + "'");
    }
    const std::string key = item.substr(0, eq);
    const std::string value = item.substr(eq + 1);
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError(source, "unknown option '" + key + "' (" + *name + " takes " + list + ")");
    }
    if (!seen.emplace(key, value).second) {
      throw InputError(source, "option '" + key + "' given twice");
    }
    if (key == "edge") {
      if (value != "partial" && value != "binary") {
        throw InputError(source, "edge must be partial or binary, got '" + value + "'");
      }
      opt.binary_edge = value == "binary";
    } else if (key == "dims") {
      std::int64_t v = 0;
      if (!parse_int(value, &v) || v < 1 || v > 1024) {
        throw InputError(source, "dims must be an integer in [1, 1024], got '" + value + "'");
      }
      opt.dims = static_cast<int>(v);
    } else {
      double v = 0.0;
      if (!parse_double(value, &v) || !std::isfinite(v)) {
        throw InputError(source, key + " must be a number, got '" + value + "'");
      }
      if (key == "fill") {
        if (v < 0.0 || v > 1.0) throw InputError(source, "fill must lie in [0, 1], got " + value);
        opt.fill = v;
      } else {
        if (v <= 0.0) throw InputError(source, key + " must be positive, got " + value);
        (key == "voxel_mm" ? opt.voxel_mm : opt.radius_mm) = v;
      }
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return opt;
}

}  // namespace

DensityField generate_volume(const std::string& spec) {
  std::string name;
  const GeneratorOptions options = parse_generator(spec, &name);
  return find_generator(name)->make(options);
}

bool is_generator_spec(const std::string& spec) {
  if (find_generator(spec.substr(0, spec.find(':'))) == nullptr) return false;
  std::error_code ec;
  return !fs::exists(spec, ec);
}

}  // namespace hapvox::engine::io
