#pragma once
// `hapvox mesh ... --tetgen-out PREFIX --tetgen tetgen`: TetGen's mesh of the same label
// boundaries, for comparison (issue 9: TetGen is AGPL-3, so it is never linked; its Debian
// program is run on the files of engine/proxy/tetgen_files.h). TetGen meshes PREFIX.smesh
// (the proxy mesh's outer surface and label boundaries, kept as they are: -Y) with its
// quality bound (-q: radius-edge ratio 2, minimum dihedral angle 0 by default), and each of
// its tets takes the label of the proxy tet its centroid lies in.

#include <map>
#include <string>

#include "engine/fem/tet_mesh.h"
#include "engine/proxy/proxy_mesh.h"

namespace hapvox::cli {

struct TetgenMesh {
  engine::fem::TetMesh mesh;
  engine::fem::MeshQuality quality;
  std::map<std::int32_t, double> volume_mm3_by_label;
  double seconds = 0.0;  // TetGen's run, wall time
};

/// Throws InputError("--tetgen", ...) unless `program` names an executable (a path, or a
/// name found on PATH): checked before anything is built.
void check_tetgen_program(const std::string& program);

/// Runs `program` (e.g. "tetgen", looked up on PATH) as `program -pYqQ PREFIX.smesh`, its
/// output to PREFIX.tetgen.log, and reads PREFIX.1.node/.1.ele. Throws InputError("--tetgen",
/// ...) when it cannot be started or fails, and the reader's errors for its files.
TetgenMesh mesh_with_tetgen(const engine::proxy::ProxyMesh& proxy, const std::string& program,
                            const std::string& prefix);

}  // namespace hapvox::cli
