#include "engine/volume_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <openvdb/io/File.h>

#include <filesystem>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/io_test_util.h"
#include "test_data.h"

namespace hapvox::engine {
namespace {

using namespace ::hapvox::engine::io_test;  // NOLINT(build/namespaces)

TEST(VolumeIoVdb, WriteReadRoundTrip) {
  const DensityField field = make_test_field();
  const std::string path = scratch_dir() + "/field.vdb";
  write_vdb(field, path);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  // The field's own grid is untouched by naming and metadata.
  EXPECT_EQ(field.grid()["hapvox_dims"], nullptr);

  const DensityField back = read_vdb(path);
  EXPECT_EQ(back.dims(), field.dims());
  EXPECT_TRUE(back.voxel_size_mm().isApprox(field.voxel_size_mm(), 1e-12));
  EXPECT_TRUE(back.origin_mm().isApprox(field.origin_mm(), 1e-12));
  EXPECT_EQ(back.active_voxel_count(), field.active_voxel_count());
  auto acc = back.grid().getConstAccessor();
  for (auto it = field.grid().cbeginValueOn(); it; ++it) {
    ASSERT_TRUE(acc.isValueOn(it.getCoord()));
    ASSERT_EQ(acc.getValue(it.getCoord()), *it);
  }
  // Same through load_volume.
  EXPECT_EQ(load_volume(path, {}).active_voxel_count(), field.active_voxel_count());
}

TEST(VolumeIoVdb, FirstFloatGridAndBoundingBoxDims) {
  initialize_openvdb();
  const std::string path = scratch_dir() + "/other.vdb";
  auto ints = openvdb::Int32Grid::create(0);
  ints->setName("density");  // right name, wrong type: skipped
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("fog");
  grid->tree().setValueOn(openvdb::Coord(3, 4, 5), 0.5f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
  openvdb::io::File(path).write(openvdb::GridCPtrVec{ints, grid});

  const DensityField field = read_vdb(path);
  EXPECT_EQ(field.dims(), Vec3i(4, 5, 6));
  EXPECT_EQ(field.voxel_size_mm(), Vec3d::Constant(0.25));
  EXPECT_EQ(field.origin_mm(), Vec3d::Zero());
  EXPECT_DOUBLE_EQ(field.total_density(), 0.5);
}

TEST(VolumeIoVdbErrors, MissingNotVdbNoFloatGrid) {
  initialize_openvdb();
  const std::string dir = scratch_dir();
  expect_input_error([&] { read_vdb(dir + "/missing.vdb"); }, dir + "/missing.vdb",
                     "cannot open file");

  write_file(dir + "/text.vdb", "this is not a vdb file\n");
  expect_input_error([&] { read_vdb(dir + "/text.vdb"); }, dir + "/text.vdb", "not a VDB file");

  auto ints = openvdb::Int32Grid::create(0);
  ints->setName("density");
  openvdb::io::File(dir + "/ints.vdb").write(openvdb::GridCPtrVec{ints});
  expect_input_error([&] { read_vdb(dir + "/ints.vdb"); }, dir + "/ints.vdb", "no float grid");

  auto level_set = openvdb::FloatGrid::create(3.0f);
  level_set->setGridClass(openvdb::GRID_LEVEL_SET);
  openvdb::io::File(dir + "/ls.vdb").write(openvdb::GridCPtrVec{level_set});
  expect_input_error([&] { read_vdb(dir + "/ls.vdb"); }, dir + "/ls.vdb", "level set");
}

// ---- generators ----------------------------------------------------------------------

TEST(VolumeIoVdb, TurnedGridKeepsItsDirection) {
  const DensityField plain = make_test_field();
  const Mat3d turn = Eigen::AngleAxisd(0.9, Vec3d(1, 1, 0).normalized()).toRotationMatrix();
  const DensityField field(plain.grid().deepCopy(), plain.voxel_size_mm(), plain.origin_mm(),
                           plain.dims(), turn);
  // The grid's own transform places it in other tools (Blender): voxel (1, 2, 3) lands where
  // the field says.
  const openvdb::Vec3d w = field.grid().transform().indexToWorld(openvdb::Vec3d(1, 2, 3));
  EXPECT_TRUE(Vec3d(w.x(), w.y(), w.z()).isApprox(field.index_to_world(Vec3d(1, 2, 3)), 1e-12));
  const std::string path = scratch_dir() + "/turned.vdb";
  write_vdb(field, path);
  const DensityField back = read_vdb(path);
  EXPECT_TRUE(back.direction().isApprox(turn, 1e-12));
  EXPECT_TRUE(back.voxel_size_mm().isApprox(field.voxel_size_mm(), 1e-12));
  EXPECT_TRUE(back.origin_mm().isApprox(field.origin_mm(), 1e-12));
  EXPECT_EQ(back.total_density(), field.total_density());
}

}  // namespace
}  // namespace hapvox::engine
