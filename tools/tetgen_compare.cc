#include "tools/tetgen_compare.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "engine/errors.h"
#include "engine/fem/field_transfer.h"
#include "engine/proxy/tetgen_files.h"

extern char** environ;

namespace hapvox::cli {
namespace {

// Runs argv[0] (looked up on PATH) with stdout and stderr to `log_path`; its exit status.
int run_program(const std::vector<std::string>& args, const std::string& log_path) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  // Checked here: posix_spawn would report a log it cannot open as the program's failure.
  if (FILE* log = std::fopen(log_path.c_str(), "w")) {
    std::fclose(log);
  } else {
    throw InputError(log_path, "cannot create file");
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    throw InputError("--tetgen", "cannot run '" + args[0] + "': " + std::strerror(spawned) +
                                     " (Debian: apt install tetgen)");
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      throw InputError("--tetgen", "lost '" + args[0] + "': " + std::strerror(errno));
    }
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace

void check_tetgen_program(const std::string& program) {
  const auto executable = [](const std::string& path) { return access(path.c_str(), X_OK) == 0; };
  bool found = program.find('/') != std::string::npos && executable(program);
  if (program.find('/') == std::string::npos) {
    const char* path = std::getenv("PATH");
    std::string dirs = path != nullptr ? path : "";
    for (std::size_t start = 0; !found && start <= dirs.size();) {
      const std::size_t end = std::min(dirs.find(':', start), dirs.size());
      const std::string dir = dirs.substr(start, end - start);
      found = !dir.empty() && executable(dir + "/" + program);
      start = end + 1;
    }
  }
  if (!found) {
    throw InputError("--tetgen",
                     "no program '" + program + "' to run (Debian: apt install tetgen)");
  }
}

TetgenMesh mesh_with_tetgen(const engine::proxy::ProxyMesh& proxy, const std::string& program,
                            const std::string& prefix) {
  const std::string log = prefix + ".tetgen.log";
  const auto start = std::chrono::steady_clock::now();
  const int status = run_program({program, "-pYqQ", prefix + ".smesh"}, log);
  TetgenMesh out;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (status != 0) {
    throw InputError("--tetgen", "'" + program + "' exited with status " + std::to_string(status) +
                                     " (its output: " + log + ")");
  }
  out.mesh = engine::proxy::read_tetgen_mesh(prefix + ".1");
  // Each tet's label: the proxy tet holding its centroid (TetGen kept every label boundary,
  // so a tet lies in one label's region).
  Eigen::Matrix3Xd centroids(3, out.mesh.tet_count());
  for (int t = 0; t < out.mesh.tet_count(); ++t) {
    centroids.col(t).setZero();
    for (const std::int32_t v : out.mesh.tets[t])
      centroids.col(t) += 0.25 * out.mesh.rest_mm.col(v);
  }
  const std::vector<engine::fem::TetPoint> located =
      engine::fem::locate_points(proxy.mesh, centroids);
  for (int t = 0; t < out.mesh.tet_count(); ++t) {
    out.mesh.labels[t] = proxy.mesh.labels[located[t].tet];
    const engine::fem::Tet& tet = out.mesh.tets[t];
    out.volume_mm3_by_label[out.mesh.labels[t]] +=
        engine::fem::signed_volume_mm3(out.mesh.rest_mm.col(tet[0]), out.mesh.rest_mm.col(tet[1]),
                                       out.mesh.rest_mm.col(tet[2]), out.mesh.rest_mm.col(tet[3]));
  }
  out.quality = engine::fem::mesh_quality(out.mesh);
  return out;
}

}  // namespace hapvox::cli
