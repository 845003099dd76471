// CI's Slurm stage (.ci/run): the 12-row sweep of sweep_cli_test.cc run by a real Slurm
// (`hapvox sweep --slurm --wait`, a job array on the one-node cluster scripts/slurm_local.sh
// starts) gives the sessions the local pool gives, bit for bit but for the timings.
// Not a ctest test: it needs the cluster, so CI runs this binary in that stage alone, with
// SLURM_CONF set; without a cluster it fails (it never skips).

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "test_data.h"
#include "tools/sweep_testing.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;

TEST(SweepSlurm, AJobArrayOnARealSlurmGivesTheLocalPoolsSessions) {
  const char* conf = std::getenv("SLURM_CONF");
  ASSERT_NE(conf, nullptr) << "SLURM_CONF is not set: start a cluster with "
                              "scripts/slurm_local.sh start DIR";
  ASSERT_EQ(std::system("sinfo > /dev/null"), 0) << "sinfo fails: no Slurm controller answers";
  const std::string dir = testing::scratch_dir();
  testing::write_traces(dir);
  testing::write_twelve_row_manifest(dir);
  const testing::CommandResult local =
      testing::run_hapvox("sweep " + dir + "/sweep.toml -o " + dir + "/local -j 2");
  ASSERT_EQ(local.exit_code, 0) << local.out << local.err;
  // The nodes find hapvox on the PATH sbatch passes on.
  const std::string path =
      "PATH=" + fs::path(testing::hapvox_binary()).parent_path().string() + ":$PATH";
  const testing::CommandResult slurm = testing::run_hapvox_env(
      path, "sweep " + dir + "/sweep.toml -o " + dir + "/slurm --slurm --wait --max-parallel 2");
  ASSERT_EQ(slurm.exit_code, 0) << slurm.out << slurm.err;
  EXPECT_NE(slurm.out.find("(12 to run, as a Slurm job array"), std::string::npos) << slurm.out;
  EXPECT_NE(slurm.out.find("12 done, 0 failed, 0 not run"), std::string::npos) << slurm.out;
  // 12 rows, 4 a task: a job array of 3 tasks, each of whose output Slurm wrote.
  int task_outputs = 0;
  for (const auto& e : fs::directory_iterator(dir + "/slurm/slurm")) {
    task_outputs += e.path().extension() == ".out";
  }
  EXPECT_EQ(task_outputs, 3);
  const auto summary = testing::read_summary(dir + "/slurm/summary.csv");
  const auto expected = testing::read_summary(dir + "/local/summary.csv");
  ASSERT_EQ(summary.size(), 12u);
  for (std::size_t i = 0; i < summary.size(); ++i) {
    const std::string id = expected[i].at("id");
    EXPECT_EQ(summary[i].at("id"), id);
    EXPECT_EQ(summary[i].at("status"), "done");
    EXPECT_EQ(summary[i].at("peak_force_n"), expected[i].at("peak_force_n"));
    testing::expect_same_sessions(dir + "/local/" + id + ".h5", dir + "/slurm/" + id + ".h5");
  }
}

}  // namespace
}  // namespace hapvox
