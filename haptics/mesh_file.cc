#include "haptics/mesh_file.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "engine/errors.h"
#include "haptics/hdf5_id.h"

namespace hapvox::haptics {
namespace {

namespace fs = std::filesystem;
using engine::proxy::ProxyMesh;

void check(bool ok, const std::string& what) {
  if (!ok) throw InputError("mesh", "cannot write " + what);
}

void write_text_attribute(hid_t object, const char* name, const std::string& value) {
  const H5Id type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), value.size() + 1);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  const H5Id space(H5Screate(H5S_SCALAR), H5Sclose);
  const H5Id attr(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
                  H5Aclose);
  check(attr.valid() && H5Awrite(attr.get(), type.get(), value.c_str()) >= 0, name);
}

// A 1-D attribute of `count` values (a scalar when count is 0).
void write_number_attribute(hid_t object, const char* name, hid_t file_type, hid_t mem_type,
                            const void* data, hsize_t count = 0) {
  const H5Id space(count == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &count, nullptr),
                   H5Sclose);
  const H5Id attr(H5Acreate2(object, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                  H5Aclose);
  check(attr.valid() && H5Awrite(attr.get(), mem_type, data) >= 0, name);
}

void write_int_attribute(hid_t object, const char* name, std::int64_t value) {
  write_number_attribute(object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
}
void write_double_attribute(hid_t object, const char* name, double value) {
  write_number_attribute(object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

// A dataset of `rows` x `columns` (1-D when columns is 0), with a units attribute when given.
void write_dataset(hid_t group, const char* name, hid_t file_type, hid_t mem_type, hsize_t rows,
                   hsize_t columns, const void* data, const char* units) {
  const hsize_t dims[2] = {rows, columns};
  const H5Id space(H5Screate_simple(columns == 0 ? 1 : 2, dims, nullptr), H5Sclose);
  const H5Id dataset(
      H5Dcreate2(group, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose);
  check(dataset.valid(), name);
  if (rows > 0) {
    check(H5Dwrite(dataset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0, name);
  }
  if (units != nullptr) write_text_attribute(dataset.get(), "units", units);
}

void write_report(hid_t group, const ProxyMesh& proxy) {
  const engine::fem::ConformingMeshReport& r = proxy.report;
  write_int_attribute(group, "vertex_count", proxy.mesh.vertex_count());
  write_int_attribute(group, "tet_count", proxy.mesh.tet_count());
  write_int_attribute(group, "fixed_vertex_count", engine::proxy::fixed_vertex_count(proxy));
  write_double_attribute(group, "min_dihedral_deg", r.quality.min_dihedral_deg);
  write_double_attribute(group, "max_dihedral_deg", r.quality.max_dihedral_deg);
  write_double_attribute(group, "total_volume_mm3", r.quality.total_volume_mm3);
  write_int_attribute(group, "warped_vertices", r.warped_vertices);
  write_int_attribute(group, "cut_tets", r.cut_tets);
  write_int_attribute(group, "unresolved_tets", r.unresolved_tets);
  write_double_attribute(group, "build_seconds", r.build_seconds);
  write_text_attribute(group, "materials_source", proxy.materials_source);
  // Per label, as three arrays in label order.
  std::vector<std::int32_t> labels;
  std::vector<double> volumes;
  std::vector<double> errors;
  for (const auto& [label, volume] : r.volume_mm3_by_label) {
    labels.push_back(label);
    volumes.push_back(volume);
    const auto error = r.relative_volume_error_by_label.find(label);
    errors.push_back(error == r.relative_volume_error_by_label.end()
                         ? std::numeric_limits<double>::quiet_NaN()
                         : error->second);
  }
  if (labels.empty()) return;
  write_number_attribute(group, "labels", H5T_STD_I32LE, H5T_NATIVE_INT32, labels.data(),
                         labels.size());
  write_number_attribute(group, "volume_mm3_by_label", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                         volumes.data(), volumes.size());
  write_number_attribute(group, "relative_volume_error_by_label", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                         errors.data(), errors.size());
}

std::string data_item(const std::string& dims, const char* number_type, int precision,
                      const std::string& h5_file_name, const std::string& dataset) {
  std::ostringstream out;
  out << "<DataItem Dimensions=\"" << dims << "\" NumberType=\"" << number_type << "\" Precision=\""
      << precision << "\" Format=\"HDF\">" << h5_file_name << ":" << dataset << "</DataItem>";
  return out.str();
}

// The topology, geometry and the mesh's own attributes of one grid, indented by `pad`.
std::string grid_body(const std::string& h5, int vertex_count, int tet_count,
                      const std::string& pad, const std::string& mesh = "/mesh") {
  const std::string v = std::to_string(vertex_count);
  const std::string t = std::to_string(tet_count);
  std::ostringstream out;
  out << pad << "<Topology TopologyType=\"Tetrahedron\" NumberOfElements=\"" << t << "\">\n"
      << pad << "  " << data_item(t + " 4", "Int", 4, h5, mesh + "/tets") << "\n"
      << pad << "</Topology>\n"
      << pad << "<Geometry GeometryType=\"XYZ\">\n"
      << pad << "  " << data_item(v + " 3", "Float", 8, h5, mesh + "/rest_mm") << "\n"
      << pad << "</Geometry>\n"
      << pad << "<Attribute Name=\"label\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
      << pad << "  " << data_item(t, "Int", 4, h5, mesh + "/tet_label") << "\n"
      << pad << "</Attribute>\n"
      << pad << "<Attribute Name=\"youngs_modulus_pa\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
      << pad << "  " << data_item(t, "Float", 8, h5, mesh + "/youngs_modulus_pa") << "\n"
      << pad << "</Attribute>\n"
      << pad << "<Attribute Name=\"vertex_class\" AttributeType=\"Scalar\" Center=\"Node\">\n"
      << pad << "  " << data_item(v, "UChar", 1, h5, mesh + "/vertex_class") << "\n"
      << pad << "</Attribute>\n";
  return out.str();
}

constexpr const char* kXdmfHeader =
    "<?xml version=\"1.0\" ?>\n"
    "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
    "  <Domain>\n";
constexpr const char* kXdmfFooter =
    "  </Domain>\n"
    "</Xdmf>\n";

// What XDMF text may hold of a file name: no markup characters.
std::string xml_escaped(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace

void write_proxy_mesh(hid_t file, const ProxyMesh& proxy) {
  const engine::fem::TetMesh& mesh = proxy.mesh;
  const hsize_t v = static_cast<hsize_t>(mesh.vertex_count());
  const hsize_t t = static_cast<hsize_t>(mesh.tet_count());
  const H5Id group(H5Gcreate2(file, "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  check(group.valid(), "/mesh");
  const hid_t g = group.get();
  // Eigen's 3 x V column-major storage is V x 3 row-major: as HDF5 wants it.
  write_dataset(g, "rest_mm", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, v, 3, mesh.rest_mm.data(), "mm");
  write_dataset(g, "tets", H5T_STD_I32LE, H5T_NATIVE_INT32, t, 4, mesh.tets.data(), nullptr);
  write_dataset(g, "tet_label", H5T_STD_I32LE, H5T_NATIVE_INT32, t, 0, mesh.labels.data(), nullptr);
  std::vector<double> youngs(t);
  std::vector<double> poisson(t);
  for (hsize_t i = 0; i < t; ++i) {
    youngs[i] = proxy.materials[i].youngs_pa;
    poisson[i] = proxy.materials[i].poisson;
  }
  write_dataset(g, "youngs_modulus_pa", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, t, 0, youngs.data(),
                "Pa");
  write_dataset(g, "poisson_ratio", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, t, 0, poisson.data(), "1");
  static_assert(sizeof(engine::fem::VertexClass) == 1);
  write_dataset(g, "vertex_class", H5T_STD_U8LE, H5T_NATIVE_UINT8, v, 0,
                proxy.vertex_classes.data(), nullptr);
  {
    const H5Id classes(H5Dopen2(g, "vertex_class", H5P_DEFAULT), H5Dclose);
    write_text_attribute(classes.get(), "values", "0 free, 1 constrained, 2 fixed");
  }
  write_report(g, proxy);
}

std::string xdmf_path_for(const std::string& h5_path) {
  return fs::path(h5_path).replace_extension(".xdmf").string();
}

std::string mesh_xdmf(const std::string& h5_file_name, int vertex_count, int tet_count) {
  std::ostringstream out;
  out << kXdmfHeader << "    <Grid Name=\"mesh\" GridType=\"Uniform\">\n"
      << grid_body(xml_escaped(h5_file_name), vertex_count, tet_count, "      ") << "    </Grid>\n"
      << kXdmfFooter;
  return out.str();
}

void write_mesh_file(const std::string& path, const ProxyMesh& proxy) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  engine::io::OutputFile out(path);
  try {
    H5Id file(create_hdf5_output(out), H5Fclose);
    try {
      write_proxy_mesh(file.get(), proxy);
    } catch (const InputError& e) {
      throw InputError(path, e.problem());
    }
    if (!file.close()) throw InputError(path, "failed to finish writing the mesh file");
    engine::io::write_text_atomically(xdmf_path_for(path),
                                      mesh_xdmf(fs::path(path).filename().string(),
                                                proxy.mesh.vertex_count(), proxy.mesh.tet_count()));
    out.commit();
  } catch (...) {
    out.discard();
    throw;
  }
}

void write_xdmf_time_series(const std::string& xdmf_path, const std::string& h5_file_name,
                            int vertex_count, int tet_count, const std::vector<double>& times_s,
                            const std::string& displacement_dataset) {
  write_xdmf_time_series(
      xdmf_path, h5_file_name,
      {XdmfSeries{"/mesh", vertex_count, tet_count, times_s, displacement_dataset}});
}

void write_xdmf_time_series(const std::string& xdmf_path, const std::string& h5_file_name,
                            const std::vector<XdmfSeries>& series) {
  const std::string h5 = xml_escaped(h5_file_name);
  std::ostringstream out;
  out.precision(17);
  out << kXdmfHeader
      << "    <Grid Name=\"displacement\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  std::size_t grid = 0;
  for (const XdmfSeries& one : series) {
    const std::string v = std::to_string(one.vertex_count);
    const std::string steps = std::to_string(one.times_s.size());
    const std::string mesh = xml_escaped(one.mesh_group);
    for (std::size_t step = 0; step < one.times_s.size(); ++step, ++grid) {
      const std::string pad = "        ";
      out << "      <Grid Name=\"step " << grid << "\" GridType=\"Uniform\">\n"
          << pad << "<Time Value=\"" << one.times_s[step] << "\"/>\n"
          << grid_body(h5, one.vertex_count, one.tet_count, pad, mesh) << pad
          << "<Attribute Name=\"displacement_mm\" AttributeType=\"Vector\" Center=\"Node\">\n"
          << pad << "  <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " << v
          << " 3\" Type=\"HyperSlab\">\n"
          // Start, stride and count per axis of the (steps, V, 3) dataset.
          << pad << "    <DataItem Dimensions=\"3 3\" Format=\"XML\">" << step << " 0 0 1 1 1 1 "
          << v << " 3</DataItem>\n"
          << pad << "    "
          << data_item(steps + " " + v + " 3", "Float", 8, h5,
                       xml_escaped(one.displacement_dataset))
          << "\n"
          << pad << "  </DataItem>\n"
          << pad << "</Attribute>\n"
          << "      </Grid>\n";
    }
  }
  out << "    </Grid>\n" << kXdmfFooter;
  engine::io::write_text_atomically(xdmf_path, out.str());
}

namespace {

template <typename T>
std::vector<T> read_vector(hid_t group, const char* name, hid_t mem_type, const std::string& path) {
  const H5Id dataset(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!dataset.valid()) throw InputError(path, std::string("no dataset /mesh/") + name);
  const H5Id space(H5Dget_space(dataset.get()), H5Sclose);
  std::vector<T> values(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.get())));
  if (!values.empty() &&
      H5Dread(dataset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    throw InputError(path, std::string("cannot read dataset /mesh/") + name);
  }
  return values;
}

template <typename T>
std::vector<T> read_attribute(hid_t group, const char* name, hid_t mem_type) {
  if (H5Aexists(group, name) <= 0) return {};
  const H5Id attr(H5Aopen(group, name, H5P_DEFAULT), H5Aclose);
  const H5Id space(H5Aget_space(attr.get()), H5Sclose);
  std::vector<T> values(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space.get())));
  if (H5Aread(attr.get(), mem_type, values.data()) < 0) return {};
  return values;
}

std::string read_text_attribute(hid_t group, const char* name) {
  if (H5Aexists(group, name) <= 0) return "";
  const H5Id attr(H5Aopen(group, name, H5P_DEFAULT), H5Aclose);
  const H5Id type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get())) return "";
  std::string text(H5Tget_size(type.get()), '\0');
  if (H5Aread(attr.get(), type.get(), text.data()) < 0) return "";
  return text.c_str();
}

}  // namespace

bool has_mesh_group(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (!fs::exists(path) || H5Fis_hdf5(path.c_str()) <= 0) return false;
  const H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  return file.valid() && H5Lexists(file.get(), "mesh", H5P_DEFAULT) > 0;
}

MeshFileInfo read_mesh_info(const std::string& path) {
  if (!has_mesh_group(path)) throw InputError(path, "not a mesh file (no /mesh group)");
  const H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  const H5Id group(H5Gopen2(file.get(), "mesh", H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw InputError(path, "cannot open /mesh");
  const hid_t g = group.get();
  MeshFileInfo info;
  const auto labels = read_vector<std::int32_t>(g, "tet_label", H5T_NATIVE_INT32, path);
  const auto youngs = read_vector<double>(g, "youngs_modulus_pa", H5T_NATIVE_DOUBLE, path);
  const auto poisson = read_vector<double>(g, "poisson_ratio", H5T_NATIVE_DOUBLE, path);
  const auto classes = read_vector<std::uint8_t>(g, "vertex_class", H5T_NATIVE_UINT8, path);
  if (youngs.size() != labels.size() || poisson.size() != labels.size()) {
    throw InputError(path,
                     "/mesh: tet_label, youngs_modulus_pa and poisson_ratio differ in length");
  }
  info.vertex_count = static_cast<int>(classes.size());
  info.tet_count = static_cast<int>(labels.size());
  for (std::uint8_t c : classes) {
    info.fixed_vertex_count += c == static_cast<std::uint8_t>(engine::fem::VertexClass::kFixed);
  }
  for (std::size_t t = 0; t < labels.size(); ++t) {
    MeshFileInfo::Label& label = info.labels[labels[t]];
    if (label.tet_count++ == 0) {
      label.youngs_pa = youngs[t];
      label.poisson = poisson[t];
      label.relative_volume_error = std::numeric_limits<double>::quiet_NaN();
    }
  }
  const auto dihedral_min = read_attribute<double>(g, "min_dihedral_deg", H5T_NATIVE_DOUBLE);
  const auto dihedral_max = read_attribute<double>(g, "max_dihedral_deg", H5T_NATIVE_DOUBLE);
  if (dihedral_min.size() == 1) info.min_dihedral_deg = dihedral_min[0];
  if (dihedral_max.size() == 1) info.max_dihedral_deg = dihedral_max[0];
  info.materials_source = read_text_attribute(g, "materials_source");
  const auto report_labels = read_attribute<std::int32_t>(g, "labels", H5T_NATIVE_INT32);
  const auto volumes = read_attribute<double>(g, "volume_mm3_by_label", H5T_NATIVE_DOUBLE);
  const auto errors =
      read_attribute<double>(g, "relative_volume_error_by_label", H5T_NATIVE_DOUBLE);
  if (volumes.size() == report_labels.size() && errors.size() == report_labels.size()) {
    for (std::size_t i = 0; i < report_labels.size(); ++i) {
      const auto found = info.labels.find(report_labels[i]);
      if (found == info.labels.end()) continue;
      found->second.volume_mm3 = volumes[i];
      found->second.relative_volume_error = errors[i];
    }
  }
  return info;
}

engine::fem::TetMesh read_tet_mesh(const std::string& path, const std::string& group_path) {
  if (!has_mesh_group(path)) throw InputError(path, "not a mesh file (no /mesh group)");
  const H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const H5Id group(H5Gopen2(file.get(), group_path.c_str(), H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw InputError(path, "cannot open /" + group_path);
  const auto rest = read_vector<double>(group.get(), "rest_mm", H5T_NATIVE_DOUBLE, path);
  const auto tets = read_vector<std::int32_t>(group.get(), "tets", H5T_NATIVE_INT32, path);
  auto labels = read_vector<std::int32_t>(group.get(), "tet_label", H5T_NATIVE_INT32, path);
  if (rest.size() % 3 != 0 || tets.size() != 4 * labels.size()) {
    throw InputError(path, "/mesh: rest_mm is not V x 3 or tets is not (tet_label's length) x 4");
  }
  engine::fem::TetMesh mesh;
  mesh.rest_mm = Eigen::Map<const Eigen::Matrix3Xd>(rest.data(), 3,
                                                    static_cast<Eigen::Index>(rest.size() / 3));
  mesh.tets.resize(labels.size());
  for (std::size_t t = 0; t < labels.size(); ++t) {
    for (int a = 0; a < 4; ++a) mesh.tets[t][static_cast<std::size_t>(a)] = tets[4 * t + a];
  }
  mesh.labels = std::move(labels);
  engine::fem::validate(mesh, path);
  return mesh;
}

}  // namespace hapvox::haptics
