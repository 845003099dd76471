// What every replay writes about its run (tools/replay_output.cc).

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "haptics/session.h"
#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;
using testing::scratch_dir;

TEST(ReplayOutput, TheSessionRecordsTheVolumesDirectionCosines) {
  const std::string dir = scratch_dir();
  // 8^3 voxels whose i axis points along world y and j along -x (a quarter turn about z).
  std::ofstream nrrd(dir + "/turned.nrrd", std::ios::binary);
  nrrd << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nspace: left-posterior-superior\n"
          "space directions: (0,2,0) (-2,0,0) (0,0,2)\nspace origin: (0,0,0)\nendian: little\n"
          "encoding: raw\n\n"
       << std::string(512, '\x80');
  nrrd.close();
  std::ofstream(dir + "/t.csv") << "t,x,y,z\n0,100,100,100\n0.01,101,100,100\n";
  const auto r = run_hapvox("replay " + dir + "/t.csv --volume " + dir +
                            "/turned.nrrd --threshold 1 -q -o " + dir + "/s.h5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string direction;
  for (const auto& [key, value] : haptics::read_session_info(dir + "/s.h5").attributes) {
    if (key == "volume_direction") direction = value;
  }
  // Rows of the matrix whose columns are the axes: i -> (0,1,0), j -> (-1,0,0), k -> z.
  EXPECT_EQ(direction, "0,-1,0;1,0,0;0,0,1");
}

}  // namespace
}  // namespace hapvox
