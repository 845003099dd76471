#include "haptics/mesh_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "engine/errors.h"
#include "engine/proxy/label_source.h"
#include "haptics/session.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

namespace fs = std::filesystem;
using engine::proxy::ProxyMesh;

// The four-spheres phantom at 16^3 with data/four_spheres.toml.
const ProxyMesh& small_mesh() {
  static const ProxyMesh mesh = [] {
    const auto intensity = engine::labels::read_scalar_volume("four-spheres:dims=16");
    const auto materials =
        engine::labels::read_materials(hapvox::testing::source_path("data/four_spheres.toml"));
    const auto labels = engine::proxy::proxy_labels(intensity, materials, {});
    return engine::proxy::build_proxy_mesh(labels, materials);
  }();
  return mesh;
}

bool python_has(const char* module) {
  const std::string command =
      std::string("/usr/bin/python3 -c 'import ") + module + "' 2>/dev/null";
  return std::system(command.c_str()) == 0;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(MeshFile, ArraysReadBackExactly) {
  const ProxyMesh& proxy = small_mesh();
  const std::string path = hapvox::testing::scratch_dir() + "/mesh.h5";
  write_mesh_file(path, proxy);
  EXPECT_TRUE(fs::exists(path));
  EXPECT_FALSE(fs::exists(path + ".partial"));
  const int v = proxy.mesh.vertex_count();
  const int t = proxy.mesh.tet_count();

  const std::vector<double> rest = read_session_column(path, "/mesh/rest_mm");
  ASSERT_EQ(rest.size(), 3u * v);
  for (int i = 0; i < v; ++i) {
    for (int a = 0; a < 3; ++a) ASSERT_EQ(rest[3 * i + a], proxy.mesh.rest_mm(a, i)) << i;
  }
  const std::vector<double> tets = read_session_column(path, "/mesh/tets");
  const std::vector<double> labels = read_session_column(path, "/mesh/tet_label");
  const std::vector<double> youngs = read_session_column(path, "/mesh/youngs_modulus_pa");
  const std::vector<double> poisson = read_session_column(path, "/mesh/poisson_ratio");
  ASSERT_EQ(tets.size(), 4u * t);
  ASSERT_EQ(labels.size(), static_cast<std::size_t>(t));
  for (int i = 0; i < t; ++i) {
    for (int k = 0; k < 4; ++k) ASSERT_EQ(tets[4 * i + k], proxy.mesh.tets[i][k]) << i;
    ASSERT_EQ(labels[i], proxy.mesh.labels[i]);
    ASSERT_EQ(youngs[i], proxy.materials[i].youngs_pa);
    ASSERT_EQ(poisson[i], proxy.materials[i].poisson);
  }
  const std::vector<double> classes = read_session_column(path, "/mesh/vertex_class");
  ASSERT_EQ(classes.size(), static_cast<std::size_t>(v));
  for (int i = 0; i < v; ++i) {
    ASSERT_EQ(classes[i], static_cast<double>(proxy.vertex_classes[i])) << i;
  }

  const MeshFileInfo info = read_mesh_info(path);
  EXPECT_EQ(info.vertex_count, v);
  EXPECT_EQ(info.tet_count, t);
  EXPECT_EQ(info.fixed_vertex_count, engine::proxy::fixed_vertex_count(proxy));
  EXPECT_GT(info.fixed_vertex_count, 0);
  EXPECT_EQ(info.min_dihedral_deg, proxy.report.quality.min_dihedral_deg);
  EXPECT_EQ(info.max_dihedral_deg, proxy.report.quality.max_dihedral_deg);
  EXPECT_EQ(info.materials_source, proxy.materials_source);
  ASSERT_EQ(info.labels.size(), 5u);
  EXPECT_EQ(info.labels.at(2).youngs_pa, 100e6);
  EXPECT_EQ(info.labels.at(4).youngs_pa, 1e6);
  EXPECT_EQ(info.labels.at(4).poisson, 0.45);
  int tets_in_labels = 0;
  for (const auto& [label, l] : info.labels) {
    tets_in_labels += l.tet_count;
    EXPECT_EQ(l.volume_mm3, proxy.report.volume_mm3_by_label.at(label));
    EXPECT_EQ(l.relative_volume_error, proxy.report.relative_volume_error_by_label.at(label));
  }
  EXPECT_EQ(tets_in_labels, t);
}

TEST(MeshFile, H5pySeesShapesTypesAndUnits) {
  if (!python_has("h5py")) GTEST_SKIP() << "python3-h5py is not installed";
  const ProxyMesh& proxy = small_mesh();
  const std::string dir = hapvox::testing::scratch_dir();
  write_mesh_file(dir + "/mesh.h5", proxy);
  const std::string v = std::to_string(proxy.mesh.vertex_count());
  const std::string t = std::to_string(proxy.mesh.tet_count());
  std::ofstream(dir + "/check.py")
      << "import h5py, numpy as np\n"
         "m = h5py.File('"
      << dir + "/mesh.h5"
      << "', 'r')['mesh']\n"
      << "assert m['rest_mm'].shape == (" << v << ", 3) and m['rest_mm'].dtype == np.float64\n"
      << "assert m['rest_mm'].attrs['units'] == b'mm' or m['rest_mm'].attrs['units'] == 'mm'\n"
      << "assert m['tets'].shape == (" << t << ", 4) and m['tets'].dtype == np.int32\n"
      << "assert m['tet_label'].dtype == np.int32 and m['vertex_class'].dtype == np.uint8\n"
      << "assert m['youngs_modulus_pa'].shape == (" << t << ",)\n"
      << "assert int(m.attrs['vertex_count']) == " << v << "\n"
      << "assert int(m.attrs['tet_count']) == " << t << "\n"
      << "assert m['tets'][:].max() == " << v << " - 1\n";
  EXPECT_EQ(std::system(("/usr/bin/python3 " + dir + "/check.py").c_str()), 0);
}

TEST(MeshFile, XdmfNamesTheDatasetsAndTheirSizes) {
  const ProxyMesh& proxy = small_mesh();
  const std::string dir = hapvox::testing::scratch_dir();
  write_mesh_file(dir + "/phantom.h5", proxy);
  ASSERT_TRUE(fs::exists(dir + "/phantom.xdmf"));
  EXPECT_FALSE(fs::exists(dir + "/phantom.xdmf.partial"));
  const std::string xdmf = hapvox::testing::read_file(dir + "/phantom.xdmf");
  const std::string v = std::to_string(proxy.mesh.vertex_count());
  const std::string t = std::to_string(proxy.mesh.tet_count());
  EXPECT_EQ(xdmf, mesh_xdmf("phantom.h5", proxy.mesh.vertex_count(), proxy.mesh.tet_count()));
  for (const std::string& piece :
       {"TopologyType=\"Tetrahedron\" NumberOfElements=\"" + t + "\"",
        "Dimensions=\"" + t +
            " 4\" NumberType=\"Int\" Precision=\"4\" "
            "Format=\"HDF\">phantom.h5:/mesh/tets<",
        std::string("GeometryType=\"XYZ\""),
        "Dimensions=\"" + v +
            " 3\" NumberType=\"Float\" Precision=\"8\" "
            "Format=\"HDF\">phantom.h5:/mesh/rest_mm<",
        "Dimensions=\"" + t +
            "\" NumberType=\"Int\" Precision=\"4\" "
            "Format=\"HDF\">phantom.h5:/mesh/tet_label<",
        std::string("Format=\"HDF\">phantom.h5:/mesh/youngs_modulus_pa<"),
        "Dimensions=\"" + v +
            "\" NumberType=\"UChar\" Precision=\"1\" "
            "Format=\"HDF\">phantom.h5:/mesh/vertex_class<"}) {
    EXPECT_EQ(count_of(xdmf, piece), 1u) << piece;
  }
  EXPECT_EQ(count_of(xdmf, "Center=\"Cell\""), 2u);
  EXPECT_EQ(count_of(xdmf, "Center=\"Node\""), 1u);
  if (python_has("xml.dom.minidom")) {
    EXPECT_EQ(std::system(("/usr/bin/python3 -c 'import sys, xml.dom.minidom; "
                           "xml.dom.minidom.parse(sys.argv[1])' " +
                           dir + "/phantom.xdmf")
                              .c_str()),
              0);
  }
}

TEST(MeshFile, TimeSeriesHasOneHyperslabGridPerStep) {
  const std::string dir = hapvox::testing::scratch_dir();
  const std::string path = dir + "/session.xdmf";
  write_xdmf_time_series(path, "session.h5", 10, 7, {0.0, 0.01, 0.02}, "/fem/displacement_mm");
  EXPECT_FALSE(fs::exists(path + ".partial"));
  const std::string xdmf = hapvox::testing::read_file(path);
  EXPECT_EQ(count_of(xdmf, "CollectionType=\"Temporal\""), 1u);
  EXPECT_EQ(count_of(xdmf, "<Time Value="), 3u);
  EXPECT_EQ(count_of(xdmf, "<Time Value=\"0.01\"/>"), 1u);
  EXPECT_EQ(count_of(xdmf, "session.h5:/mesh/tets<"), 3u);
  EXPECT_EQ(count_of(xdmf, "ItemType=\"HyperSlab\" Dimensions=\"1 10 3\""), 3u);
  EXPECT_EQ(count_of(xdmf, ">2 0 0 1 1 1 1 10 3</DataItem>"), 1u);
  EXPECT_EQ(count_of(xdmf,
                     "Dimensions=\"3 10 3\" NumberType=\"Float\" Precision=\"8\" "
                     "Format=\"HDF\">session.h5:/fem/displacement_mm<"),
            3u);
  EXPECT_EQ(count_of(xdmf, "Name=\"displacement_mm\" AttributeType=\"Vector\" Center=\"Node\""),
            3u);
  if (python_has("xml.dom.minidom")) {
    EXPECT_EQ(std::system(("/usr/bin/python3 -c 'import sys, xml.dom.minidom; "
                           "xml.dom.minidom.parse(sys.argv[1])' " +
                           path)
                              .c_str()),
              0);
  }
}

TEST(MeshFile, AFailedWriteLeavesNoFileBehind) {
  const ProxyMesh& proxy = small_mesh();
  const std::string dir = hapvox::testing::scratch_dir();
  // No such folder: nothing can be created.
  const std::string missing = dir + "/no/mesh.h5";
  EXPECT_THROW(write_mesh_file(missing, proxy), InputError);
  EXPECT_FALSE(fs::exists(dir + "/no"));
  // The XDMF file cannot take its place (a folder there): the HDF5 file written first goes too.
  const std::string path = dir + "/mesh.h5";
  fs::create_directory(dir + "/mesh.xdmf");
  try {
    write_mesh_file(path, proxy);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), dir + "/mesh.xdmf");
  }
  for (const char* name : {"mesh.h5", "mesh.h5.partial", "mesh.xdmf.partial"}) {
    EXPECT_FALSE(fs::exists(dir + "/" + name)) << name;
  }
  EXPECT_TRUE(fs::is_directory(dir + "/mesh.xdmf"));
}

TEST(MeshFile, AFileWithoutAMeshIsNamed) {
  const std::string dir = hapvox::testing::scratch_dir();
  EXPECT_FALSE(has_mesh_group(dir + "/none.h5"));
  try {
    read_mesh_info(dir + "/none.h5");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), dir + "/none.h5: not a mesh file (no /mesh group)");
  }
  EXPECT_EQ(xdmf_path_for("out/mesh.h5"), "out/mesh.xdmf");
  EXPECT_EQ(xdmf_path_for("mesh"), "mesh.xdmf");
}

}  // namespace
}  // namespace hapvox::haptics
