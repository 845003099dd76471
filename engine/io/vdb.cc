#include "engine/io/vdb.h"

#include <fcntl.h>
#include <openvdb/io/File.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <system_error>

#include "engine/check.h"
#include "engine/errors.h"
#include "engine/io/direction.h"
#include "engine/io/output_file.h"
#include "engine/io/payload.h"
#include "engine/io/raw_volume.h"

namespace hapvox::engine::io {
namespace {

namespace fs = std::filesystem;

// Densities a .vdb may hold: sculpted volumes exceed 1 where clay is compressed; far
// beyond that is a corrupt or foreign grid (and would overflow the mass grid's units).
constexpr float kMaxDensity = 1000.0f;

// OpenVDB trusts its input: bytes flipped inside a grid's data can make it allocate
// without bound, loop, or corrupt the heap rather than throw. So a .vdb is first read by a
// child process, with its memory capped (outside sanitizer builds, whose shadow memory a
// cap would break), a time limit and stderr silenced; only if that read succeeds is the
// file read here. Throws InputError saying how the child's read failed.
void check_vdb_in_child(const std::string& path) {
#if defined(__SANITIZE_THREAD__)
  // ThreadSanitizer kills the child of a multithreaded fork: there, read directly.
  std::ifstream proc_status("/proc/self/status");
  for (std::string line; std::getline(proc_status, line);) {
    if (line.rfind("Threads:", 0) == 0 && std::stoi(line.substr(8)) > 1) return;
  }
#endif
  int fds[2];
  if (pipe(fds) != 0) return;  // no child: the read below is on its own
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return;
  }
  if (pid == 0) {
    close(fds[0]);
    const int null_fd = open("/dev/null", O_WRONLY);
    if (null_fd >= 0) dup2(null_fd, STDERR_FILENO);
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages > 0 && page > 0) {
      const rlim_t half = static_cast<rlim_t>(pages) / 2 * static_cast<rlim_t>(page);
      const rlimit cap{half, half};
      setrlimit(RLIMIT_AS, &cap);
    }
#endif
    std::error_code ec;
    const auto bytes = fs::file_size(path, ec);
    alarm(30 + static_cast<unsigned>(ec ? 0 : bytes >> 20));  // 30 s plus 1 s per MB
    std::string message;
    int code = 0;
    openvdb::io::File file(path);
    try {
      file.open(false);
    } catch (const std::exception& e) {
      message = std::string("not a VDB file (") + e.what() + ")";
      code = 2;
    }
    if (code == 0) {
      try {
        file.getGrids();
        file.close();
      } catch (const std::bad_alloc&) {
        message = "corrupt or truncated VDB file (its sizes ask for more memory than exists)";
        code = 2;
      } catch (const std::exception& e) {
        message = std::string("cannot read VDB grid: ") + e.what();
        code = 2;
      }
    }
    if (write(fds[1], message.data(), message.size()) < 0) code = 3;
    _exit(code);
  }
  close(fds[1]);
  std::string message;
  char buffer[512];
  for (ssize_t n; (n = read(fds[0], buffer, sizeof buffer)) != 0;) {
    if (n > 0) {
      message.append(buffer, static_cast<std::size_t>(n));
    } else if (errno != EINTR) {
      break;
    }
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 2) throw InputError(path, message);
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM) {
    throw InputError(path, "corrupt or truncated VDB file (reading it did not finish)");
  }
  throw InputError(path, "corrupt or truncated VDB file (reading it crashed OpenVDB)");
}

struct GridGeometry {
  Vec3d voxel_size_mm;
  Vec3d origin_mm;
  Vec3i dims;
  Mat3d direction;
};

// Spacing, direction and origin from a grid's (linear) transform; dims from hapvox's
// metadata, else the active voxels' box from the origin.
GridGeometry grid_geometry(const openvdb::GridBase& grid, const std::string& path) {
  GridGeometry g;
  const openvdb::math::Transform& xform = grid.transform();
  if (!xform.isLinear()) throw InputError(path, "grid transform is not linear");
  const openvdb::Vec3d origin = xform.indexToWorld(openvdb::Vec3d(0.0));
  for (int a = 0; a < 3; ++a) {
    openvdb::Vec3d unit(0.0);
    unit[a] = 1.0;
    const openvdb::Vec3d step = xform.indexToWorld(unit) - origin;
    g.voxel_size_mm[a] = step.length();
    g.direction.col(a) = Vec3d(step.x(), step.y(), step.z()) / g.voxel_size_mm[a];
  }
  if (!g.voxel_size_mm.allFinite() || !(g.voxel_size_mm.minCoeff() > 0.0)) {
    throw InputError(path, "grid voxel size must be positive");
  }
  if (const std::string problem = direction_problem(g.direction); !problem.empty()) {
    throw InputError(path, "grid transform's axes are " + problem);
  }
  g.origin_mm = Vec3d(origin.x(), origin.y(), origin.z());
  if (auto meta = grid.getMetadata<openvdb::Vec3IMetadata>("hapvox_dims")) {
    const openvdb::Vec3i d = meta->value();
    g.dims = Vec3i(d.x(), d.y(), d.z());
    if (g.dims.minCoeff() <= 0) throw InputError(path, "hapvox_dims metadata must be positive");
  } else {
    const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    if (box.empty()) throw InputError(path, "grid \"" + grid.getName() + "\" is empty");
    g.dims = Vec3i(std::max(1, box.max().x() + 1), std::max(1, box.max().y() + 1),
                   std::max(1, box.max().z() + 1));
  }
  if (static_cast<std::int64_t>(g.dims.x()) * g.dims.y() * g.dims.z() > kMaxSamples) {
    throw InputError(path, "grid \"" + grid.getName() + "\" spans more voxels than hapvox reads");
  }
  const std::int64_t dims[3] = {g.dims.x(), g.dims.y(), g.dims.z()};
  check_volume_budget(dims, sizeof(float), "float", path);
  return g;
}

// Writes `grid` to PATH.partial (engine/io/output_file.h), then renames it to PATH.
void write_grid_atomically(const openvdb::GridBase::ConstPtr& grid, const std::string& path) {
  OutputFile out(path);
  try {
    openvdb::io::File file(out.partial_path());
    file.write(openvdb::GridCPtrVec{grid});
    file.close();
    out.verify();
    out.commit();
  } catch (const openvdb::Exception& e) {
    out.discard();
    throw InputError(path, std::string("cannot write file: ") + e.what());
  } catch (...) {
    out.discard();
    throw;
  }
}

// read_vdb once the child process read the file without harm.
DensityField read_checked_vdb(const std::string& path) {
  openvdb::io::File file(path);
  openvdb::FloatGrid::Ptr grid;
  try {
    file.open(false);  // no delayed loading: the file may be replaced while we run
  } catch (const openvdb::Exception& e) {
    throw InputError(path, std::string("not a VDB file (") + e.what() + ")");
  }
  try {
    // Prefer a float grid named "density", else the first float grid.
    std::optional<std::string> name;
    const openvdb::GridPtrVecPtr metas = file.readAllGridMetadata();
    for (const auto& meta : *metas) {
      if (!meta->isType<openvdb::FloatGrid>()) continue;
      if (!name || meta->getName() == "density") name = meta->getName();
      if (*name == "density") break;
    }
    if (name) grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(*name));
    file.close();
  } catch (const openvdb::Exception& e) {
    throw InputError(path, std::string("cannot read VDB grid: ") + e.what());
  } catch (const std::exception& e) {
    throw InputError(path, std::string("corrupt or truncated VDB file (") + e.what() + ")");
  }
  if (grid == nullptr) {
    throw InputError(path, "no float grid (expected a grid named \"density\")");
  }
  if (grid->getGridClass() == openvdb::GRID_LEVEL_SET) {
    throw InputError(
        path, "grid \"" + grid->getName() + "\" is a level set, not a density (fog volume) grid");
  }
  if (grid->background() != 0.0f) {
    throw InputError(path, "grid \"" + grid->getName() + "\" has background " +
                               std::to_string(grid->background()) + ", expected 0");
  }
  for (auto it = grid->cbeginValueOn(); it; ++it) {
    if (!std::isfinite(*it)) throw InputError(path, "grid contains NaN or infinite values");
    if (*it < 0.0f || *it > kMaxDensity) {
      throw InputError(path, "grid contains density " + std::to_string(*it) + " outside [0, " +
                                 std::to_string(static_cast<int>(kMaxDensity)) +
                                 "] (1 is the normal density)");
    }
  }
  const GridGeometry g = grid_geometry(*grid, path);
  return DensityField(grid, g.voxel_size_mm, g.origin_mm, g.dims, g.direction);
}

}  // namespace

DensityField read_vdb(const std::string& path) {
  initialize_openvdb();
  std::error_code error;  // a name too long for the system is not a file, not a crash
  if (!fs::is_regular_file(path, error)) throw InputError(path, "cannot open file");
  check_vdb_in_child(path);
  return read_checked_vdb(path);
}

void write_vdb(const DensityField& field, const std::string& path) {
  initialize_openvdb();
  // A new grid sharing the field's tree, so naming and metadata do not touch the field.
  auto grid = openvdb::FloatGrid::create(field.grid_ptr()->treePtr());
  grid->setName("density");
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  grid->setTransform(field.grid().transform().copy());  // spacing, direction, origin
  const Vec3i& d = field.dims();
  grid->insertMeta("hapvox_dims", openvdb::Vec3IMetadata(openvdb::Vec3i(d.x(), d.y(), d.z())));
  write_grid_atomically(grid, path);
}

void write_vdb_labels(const WrittenVolume& volume, const std::string& path) {
  HAPVOX_CHECK(volume.content == WrittenContent::labels);
  initialize_openvdb();
  auto grid = openvdb::Int32Grid::create(0);
  grid->setName("labels");
  // A float field over the same box gives the transform (spacing, direction, origin) that
  // write_vdb writes for densities.
  const DensityField box(openvdb::FloatGrid::create(0.0f), volume.spacing_mm, volume.origin_mm,
                         volume.dims, volume.direction);
  grid->setTransform(box.grid().transform().copy());
  const Vec3i& d = volume.dims;
  grid->insertMeta("hapvox_dims", openvdb::Vec3IMetadata(openvdb::Vec3i(d.x(), d.y(), d.z())));
  grid->insertMeta("hapvox_content", openvdb::StringMetadata("labels"));
  const std::vector<std::int32_t> labels = written_labels(volume);
  auto accessor = grid->getAccessor();
  std::size_t i = 0;
  for (int z = 0; z < d.z(); ++z) {
    for (int y = 0; y < d.y(); ++y) {
      for (int x = 0; x < d.x(); ++x, ++i) {
        if (labels[i] != 0) accessor.setValue(openvdb::Coord(x, y, z), labels[i]);
      }
    }
  }
  write_grid_atomically(grid, path);
}

RawVolume read_vdb_samples(const std::string& path) {
  initialize_openvdb();
  std::error_code error;  // a name too long for the system is not a file, not a crash
  if (!fs::is_regular_file(path, error)) throw InputError(path, "cannot open file");
  check_vdb_in_child(path);
  // A file with a float grid holds densities; one with only an Int32 grid holds labels.
  openvdb::Int32Grid::Ptr grid;
  bool has_float_grid = false;
  {
    openvdb::io::File file(path);
    try {
      file.open(false);
      std::optional<std::string> name;
      const openvdb::GridPtrVecPtr metas = file.readAllGridMetadata();
      for (const auto& meta : *metas) {
        has_float_grid = has_float_grid || meta->isType<openvdb::FloatGrid>();
        if (meta->isType<openvdb::Int32Grid>() && !name) name = meta->getName();
      }
      if (name && !has_float_grid) {
        grid = openvdb::gridPtrCast<openvdb::Int32Grid>(file.readGrid(*name));
      }
      file.close();
    } catch (const openvdb::Exception& e) {
      throw InputError(path, std::string("not a VDB file (") + e.what() + ")");
    } catch (const std::exception& e) {
      throw InputError(path, std::string("corrupt or truncated VDB file (") + e.what() + ")");
    }
  }
  if (has_float_grid) return dense_intensity(read_checked_vdb(path));
  if (grid == nullptr) {
    throw InputError(path, "no float or Int32 grid (expected a grid named \"density\")");
  }
  if (grid->background() != 0) {
    throw InputError(path, "grid \"" + grid->getName() + "\" has background " +
                               std::to_string(grid->background()) + ", expected 0");
  }
  const GridGeometry g = grid_geometry(*grid, path);
  RawVolume raw;
  raw.dims = g.dims;
  raw.spacing_mm = g.voxel_size_mm;
  raw.origin_mm = g.origin_mm;
  raw.direction = g.direction;
  raw.sample_type = "int32";
  raw.holds_labels = true;  // an integer grid holds labels, not densities
  raw.intensity.assign(static_cast<std::size_t>(g.dims.x()) * static_cast<std::size_t>(g.dims.y()) *
                           static_cast<std::size_t>(g.dims.z()),
                       0.0f);
  for (auto it = grid->cbeginValueOn(); it; ++it) {
    const openvdb::Coord c = it.getCoord();
    if (c.x() < 0 || c.y() < 0 || c.z() < 0 || c.x() >= g.dims.x() || c.y() >= g.dims.y() ||
        c.z() >= g.dims.z()) {
      continue;  // outside the box hapvox_dims names, as densities are
    }
    raw.intensity[static_cast<std::size_t>(c.x()) +
                  static_cast<std::size_t>(g.dims.x()) *
                      (static_cast<std::size_t>(c.y()) +
                       static_cast<std::size_t>(g.dims.y()) * static_cast<std::size_t>(c.z()))] =
        static_cast<float>(*it);
  }
  const auto [lo, hi] = std::minmax_element(raw.intensity.begin(), raw.intensity.end());
  raw.min_intensity = *lo;
  raw.max_intensity = *hi;
  return raw;
}

}  // namespace hapvox::engine::io
