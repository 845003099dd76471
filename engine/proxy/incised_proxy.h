#pragma once
// An incision in a proxy model (Nakao et al. 2010, §3.3): the proxy mesh split along a cut
// surface (engine/fem/incision.h) and held open by `width`: the two copies of every vertex on
// the cut are prescribed +-width/2 along the cut's normal, the paper's two face-to-face
// constraint surfaces, and the FEM finds how the rest of the body follows. The pieces of a
// tet keep its material; a vertex made on an edge is fixed when both ends of the edge are.

#include <string>

#include "engine/fem/incision.h"
#include "engine/proxy/proxy_mesh.h"

namespace hapvox::engine::proxy {

/// `proxy` incised along `cut` and opened by `width_mm` (its prescribed_mm: the earlier ones,
/// carried to the split vertices, then the opening's; the opening wins on a vertex both
/// hold). Throws InputError(source, ...) for a width that is not positive and finite, and
/// the errors of fem::incise.
ProxyMesh incise(const ProxyMesh& proxy, const fem::CutSurface& cut, double width_mm,
                 const std::string& source);

}  // namespace hapvox::engine::proxy
