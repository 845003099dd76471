#pragma once
// TetGen's file formats (.node, .ele, .smesh), for comparing hapvox's proxy mesh with TetGen's
// (`hapvox mesh --tetgen-out PREFIX`, docs/materials.md). TetGen is AGPL-3: hapvox never links
// it; these files are the whole interface, and running the `tetgen` program on them is the
// user's step (or the optional comparison in tools/).
//
//   .node   "<points> 3 <attributes> <markers>", then "<index> <x> <y> <z> ...", '#' comments
//   .ele    "<tets> 4 <region attribute 0|1>", then "<index> <n1> <n2> <n3> <n4> [<label>]"
//   .smesh  a piecewise linear complex: points, then triangular facets, holes and regions
//
// Indices start at 0 or 1 (the first point's index decides, as TetGen reads them).

#include <string>

#include "engine/fem/tet_mesh.h"

namespace hapvox::engine::proxy {

/// Writes PREFIX.node and PREFIX.ele: the mesh's rest positions (mm) and its tets, each with
/// its label as region attribute. Throws InputError(file, ...) when a file cannot be written.
void write_tetgen_mesh(const std::string& prefix, const fem::TetMesh& mesh);

/// Writes PREFIX.smesh: the mesh's outer surface and the faces between tets of different
/// labels, as triangular facets over the vertices they use (renumbered from 0; marker 1 on
/// the outer surface, 2 between labels): what TetGen meshes with `tetgen -pY PREFIX.smesh`,
/// keeping every label boundary. Returns the number of facets. Throws InputError(file, ...).
int write_tetgen_surface(const std::string& prefix, const fem::TetMesh& mesh);

/// Reads PREFIX.node and PREFIX.ele (TetGen's output, or write_tetgen_mesh's): positions in
/// mm, tets reoriented to be positive, labels from the region attribute (0 without one).
/// Throws InputError("FILE:LINE", problem) for a malformed line, an index out of range, a
/// count that does not match, or a degenerate tet; InputError(FILE, ...) when one is missing.
fem::TetMesh read_tetgen_mesh(const std::string& prefix);

}  // namespace hapvox::engine::proxy
