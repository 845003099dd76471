#pragma once
// The proxy mesh on disk (docs/formats.md): an HDF5 group /mesh (rest positions, tets, labels,
// per-tet E and nu, vertex classes, the build report as attributes), written on its own as a
// mesh file by `hapvox mesh` or into a session, and XDMF files beside them so ParaView opens
// the mesh, or a session's node displacements as a time series, straight from the HDF5.

#include <hdf5.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "engine/proxy/proxy_mesh.h"

namespace hapvox::haptics {

/// Writes group /mesh into an open HDF5 file (or group): rest_mm (V x 3 f64, mm), tets (T x 4
/// i32), tet_label (T i32), youngs_modulus_pa (T f64), poisson_ratio (T f64), vertex_class (V
/// u8: 0 free, 1 constrained, 2 fixed), and the report as attributes of /mesh. Throws
/// InputError("mesh", ...) when HDF5 refuses a write.
void write_proxy_mesh(hid_t file, const engine::proxy::ProxyMesh& proxy);

/// Writes a mesh file: PATH.partial, renamed to PATH once complete, and PATH's stem + .xdmf
/// beside it (through its own .partial). On any failure neither file nor a .partial is left
/// and InputError(path, ...) is thrown. The caller checks PATH is not an input.
void write_mesh_file(const std::string& path, const engine::proxy::ProxyMesh& proxy);

/// PATH with its extension replaced by .xdmf ("out/mesh.h5" -> "out/mesh.xdmf").
std::string xdmf_path_for(const std::string& h5_path);

/// The XDMF (3.0) text of the mesh in `h5_file_name` (as the XDMF file names it: relative to
/// the XDMF file's folder): tetrahedra and XYZ geometry from /mesh, cell attributes label and
/// youngs_modulus_pa, node attribute vertex_class.
std::string mesh_xdmf(const std::string& h5_file_name, int vertex_count, int tet_count);

/// Writes an XDMF time series of node displacements stored in `h5_file_name` as one dataset
/// `displacement_dataset` of shape (steps, V, 3) (e.g. "/fem/displacement_mm"): a temporal
/// collection with one grid per step at times_s[step], each the /mesh grid with a node
/// attribute displacement_mm read through a hyperslab of that dataset (ParaView: Warp By
/// Vector shows the deformed mesh). Written through XDMF_PATH.partial. Throws InputError.
void write_xdmf_time_series(const std::string& xdmf_path, const std::string& h5_file_name,
                            int vertex_count, int tet_count, const std::vector<double>& times_s,
                            const std::string& displacement_dataset);
/// One mesh's part of a time series: its group ("/mesh", "/fem/remesh_1/mesh"), counts, the
/// times of its steps and the (steps, V, 3) dataset of their displacements.
struct XdmfSeries {
  std::string mesh_group;
  int vertex_count = 0;
  int tet_count = 0;
  std::vector<double> times_s;
  std::string displacement_dataset;
};
/// As above, over several meshes in turn (a run whose mesh was rebuilt): one temporal
/// collection whose grids take each series' mesh.
void write_xdmf_time_series(const std::string& xdmf_path, const std::string& h5_file_name,
                            const std::vector<XdmfSeries>& series);

/// What `hapvox info` shows of a file with a /mesh group.
struct MeshFileInfo {
  int vertex_count = 0;
  int tet_count = 0;
  int fixed_vertex_count = 0;
  double min_dihedral_deg = 0;
  double max_dihedral_deg = 0;
  std::string materials_source;
  struct Label {
    int tet_count = 0;
    double volume_mm3 = 0;
    double relative_volume_error = 0;  // NaN when the mesh had no reference volume
    double youngs_pa = 0;              // of its first tet (all of a label's tets share it)
    double poisson = 0;
  };
  std::map<std::int32_t, Label> labels;
};

/// True when `path` is an HDF5 file with a /mesh group.
bool has_mesh_group(const std::string& path);

/// Reads /mesh of a mesh file or session. Throws InputError(path, ...) when there is none.
MeshFileInfo read_mesh_info(const std::string& path);

/// The rest mesh (positions, tets, labels) of /mesh (or of another mesh group, e.g. a
/// session's "fem/remesh_1/mesh"), checked with fem::validate. Throws
/// InputError(path, ...) when there is none, a dataset is missing or has the wrong shape.
engine::fem::TetMesh read_tet_mesh(const std::string& path, const std::string& group_path = "mesh");

}  // namespace hapvox::haptics
