// hapvox sweep: a 12-row manifest (3 traces x 2 materials x 2 tools) run two at a time gives
// the sessions 12 single `hapvox replay` runs give; a killed sweep reruns only its missing
// rows; a failing row is in the exit code and the summary; a bad manifest is one line
// naming its line, before any row runs.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "haptics/session.h"
#include "test_data.h"
#include "tools/sweep_testing.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::expect_same_sessions;
using testing::read_summary;
using testing::run_hapvox;
using testing::run_hapvox_env;
using testing::run_row_command_in;
using testing::scratch_dir;
using testing::write_traces;

TEST(SweepCli, TwelveRowsTwoAtATimeAreTheSessionsOfTwelveSingleReplays) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  testing::write_twelve_row_manifest(dir);
  const testing::CommandResult sweep =
      run_hapvox("sweep " + dir + "/sweep.toml -o " + dir + "/out -j 2");
  ASSERT_EQ(sweep.exit_code, 0) << sweep.err << sweep.out;
  EXPECT_NE(sweep.out.find("12 rows -> " + dir + "/out (12 to run, 2 at a time"), std::string::npos)
      << sweep.out;
  EXPECT_NE(sweep.out.find("12 done, 0 failed, 0 not run"), std::string::npos) << sweep.out;
  const auto summary = read_summary(dir + "/out/summary.csv");
  ASSERT_EQ(summary.size(), 12u);
  fs::create_directories(dir + "/single");
  std::map<std::string, double> peak_by_material;
  for (const auto& row : summary) {
    EXPECT_EQ(row.at("status"), "done");
    const std::string id = row.at("id");
    ASSERT_EQ(run_row_command_in(dir + "/out/" + id + ".cmd", dir + "/single"), 0) << id;
    expect_same_sessions(dir + "/out/" + id + ".h5", dir + "/single/" + id + ".h5");
    EXPECT_GT(std::stod(row.at("peak_force_n")), 0.05) << id;
    EXPECT_GT(std::stod(row.at("rms_force_n")), 0.0) << id;
    EXPECT_EQ(row.at("lateness_p99_us"), "");  // lockstep rows have none
    peak_by_material[row.at("materials")] += std::stod(row.at("peak_force_n"));
  }
  // The stiffer clay pushes back harder, row for row (the summary reads the sessions).
  ASSERT_EQ(peak_by_material.size(), 2u);
  EXPECT_GT(peak_by_material[dir + "/stiff.toml"],
            2.0 * peak_by_material[testing::source_path("data/clay_block.toml")]);
  // summary.h5 holds the same table: the CSV's numbers (printed with 6 digits from the
  // sessions' attributes) and NaN where the CSV has an empty cell.
  const std::string h5 = dir + "/out/summary.h5";
  const std::vector<double> peak = haptics::read_session_column(h5, "/peak_force_n");
  const std::vector<double> lateness = haptics::read_session_column(h5, "/lateness_p99_us");
  ASSERT_EQ(peak.size(), 12u);
  ASSERT_EQ(lateness.size(), 12u);
  for (std::size_t i = 0; i < 12; ++i) {
    EXPECT_EQ(peak[i], std::stod(summary[i].at("peak_force_n"))) << i;
    EXPECT_TRUE(std::isnan(lateness[i])) << i;
  }
  // The sessions' tools, as the grid set them.
  const std::vector<double> tool_mm = haptics::read_session_column(h5, "/tool_diameter_mm");
  ASSERT_EQ(tool_mm.size(), 12u);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(tool_mm[i], i % 2 == 0 ? 6.0 : 8.0) << i;
  // hapvox report DIR draws the sweep; a directory without a summary is one line.
  const testing::CommandResult report = run_hapvox("report " + dir + "/out -o " + dir + "/plots");
  ASSERT_EQ(report.exit_code, 0) << report.err;
  EXPECT_EQ(report.out, "wrote " + dir + "/plots/sweep_peak_force.png\n");
  EXPECT_EQ(testing::read_file(dir + "/plots/sweep_peak_force.png").substr(1, 3), "PNG");
  const testing::CommandResult bare = run_hapvox("report " + dir + "/single -o " + dir + "/p2");
  EXPECT_EQ(bare.exit_code, 2);
  EXPECT_EQ(bare.err, "hapvox: error: " + dir +
                          "/single: is a directory without a sweep's summary.h5 (hapvox sweep "
                          "--collect DIR writes one)\n");
  EXPECT_FALSE(fs::exists(dir + "/p2"));
}

// Stand-ins for sbatch and squeue in DIR/bin. sbatch runs each task of the job array here,
// one after another, with SLURM_ARRAY_JOB_ID (77, then 78, ...) and SLURM_ARRAY_TASK_ID set,
// and answers the job's ID. squeue lists a running and a queued task for as many calls as
// DIR/bin/running_calls says (forever while DIR/bin/running exists), then no longer knows
// the job. What the real Slurm does with the same script, CI's Slurm stage checks
// (sweep_slurm_check.cc).
std::string fake_slurm(const std::string& dir) {
  const std::string bin = dir + "/bin";
  fs::create_directories(bin);
  std::ofstream(bin + "/sbatch")
      << "#!/bin/bash\n"
         "[ \"$1\" = --parsable ] && shift\n"
         "id=$(cat "
      << bin
      << "/next_job 2>/dev/null || echo 77)\n"
         "echo $((id + 1)) > "
      << bin
      << "/next_job\n"
         "range=$(sed -n 's/^#SBATCH --array=\\([0-9]*-[0-9]*\\).*/\\1/p' \"$1\")\n"
         "for t in $(seq ${range%-*} ${range#*-}); do\n"
         "  SLURM_ARRAY_JOB_ID=$id SLURM_ARRAY_TASK_ID=$t bash \"$1\" > /dev/null 2>&1\n"
         "done\n"
         "echo $id\n";
  std::ofstream(bin + "/squeue") << "#!/bin/bash\n"
                                    "calls=$(cat "
                                 << bin
                                 << "/running_calls 2>/dev/null || echo 0)\n"
                                    "if [ -e "
                                 << bin
                                 << "/running ] || [ \"$calls\" -gt 0 ]; then\n"
                                    "  echo $((calls > 0 ? calls - 1 : 0)) > "
                                 << bin
                                 << "/running_calls\n"
                                    "  printf 'RUNNING\\nPENDING\\n'\n"
                                    "  exit 0\n"
                                    "fi\n"
                                    "echo 'slurm_load_jobs error: Invalid job id specified' >&2\n"
                                    "exit 1\n";
  fs::permissions(bin + "/sbatch", fs::perms::owner_all);
  fs::permissions(bin + "/squeue", fs::perms::owner_all);
  // The job's tasks call `hapvox` by name (the nodes' PATH).
  return "PATH=" + bin + ":" + fs::path(testing::hapvox_binary()).parent_path().string() + ":$PATH";
}

// Six rows: 3 traces x 2 tool sizes on the clay block; with `failing`, a seventh row that
// the replay refuses (a hardening slope above E, which only the run itself can judge).
void write_six_row_manifest(const std::string& dir, bool failing = false) {
  std::ofstream(dir + "/sweep.toml") << "traces = ['press16.csv', 'press24.csv', 'press32.csv']\n"
                                        "volumes = ['block:dims=48']\n"
                                        "[options]\n"
                                        "tool-diameter-mm = [6, 8]\n"
                                     << (failing ? "[[row]]\n"
                                                   "trace = 'press24.csv'\n"
                                                   "volume = 'block:dims=48'\n"
                                                   "options = { plastic = true, "
                                                   "elastoplastic-modulus-pa = 2e5 }\n"
                                                 : "");
}

TEST(SweepCli, ASlurmJobArrayRunsTheRowsTheLocalPoolRunsAndResumesWhatIsMissing) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  write_six_row_manifest(dir, /*failing=*/true);
  const std::string sweep = "sweep " + dir + "/sweep.toml -o ";
  ASSERT_EQ(run_hapvox(sweep + dir + "/local -j 2").exit_code, 101);
  const std::string path = fake_slurm(dir);
  const std::string slurm = dir + "/slurm";
  // The job's tasks run (and fail one row) while squeue still lists the job twice.
  std::ofstream(dir + "/bin/running_calls") << "2\n";
  const testing::CommandResult r = run_hapvox_env(
      path, sweep + slurm +
                " --slurm --wait --rows-per-task 4 --max-parallel 1 --partition debug --time 10");
  EXPECT_EQ(r.exit_code, 101) << r.out << r.err;
  EXPECT_NE(r.out.find("7 rows -> " + slurm + " (7 to run, as a Slurm job array"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("job 77 submitted (" + slurm + "/sweep.sbatch"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("6 done, 1 failed, 0 not run"), std::string::npos) << r.out;
  EXPECT_EQ(testing::read_file(dir + "/bin/running_calls"), "0\n");  // it was followed to the end
  EXPECT_EQ(testing::read_file(slurm + "/slurm.job"), "77\n");
  // Two tasks (4 rows, then 3), one at a time, on the partition and time asked for.
  const std::string script = testing::read_file(slurm + "/sweep.sbatch");
  EXPECT_NE(script.find("\n#SBATCH --array=0-1%1\n"), std::string::npos) << script;
  EXPECT_NE(script.find("\n#SBATCH --partition=debug\n#SBATCH --time=10\n"), std::string::npos)
      << script;
  const auto local = read_summary(dir + "/local/summary.csv");
  const auto summary = read_summary(slurm + "/summary.csv");
  ASSERT_EQ(summary.size(), 7u);
  for (std::size_t i = 0; i < 7; ++i) {
    const std::string id = local[i].at("id");
    EXPECT_EQ(summary[i].at("id"), id);
    EXPECT_EQ(summary[i].at("status"), local[i].at("status"));
    EXPECT_EQ(summary[i].at("peak_force_n"), local[i].at("peak_force_n"));
    if (i < 6) expect_same_sessions(dir + "/local/" + id + ".h5", slurm + "/" + id + ".h5");
  }
  EXPECT_EQ(summary[6].at("status"), "failed");

  // A lost session. While a job of the folder runs, nothing else may run its rows.
  const std::string lost = summary[4].at("id");
  fs::remove(slurm + "/" + lost + ".h5");
  std::ofstream(dir + "/bin/running");
  for (const char* backend : {" --emit slurm", " -j 1"}) {
    const testing::CommandResult busy = run_hapvox_env(path, sweep + slurm + backend);
    EXPECT_EQ(busy.exit_code, 2) << backend;
    EXPECT_EQ(busy.err, "hapvox: error: " + slurm +
                            ": Slurm job 77 still has 2 tasks queued or running (wait for it, or "
                            "scancel 77; hapvox sweep --collect DIR gathers it)\n")
        << backend;
  }
  const testing::CommandResult running = run_hapvox_env(path, "sweep --collect " + slurm);
  EXPECT_EQ(running.exit_code, 102) << running.out;  // 1 failed, 1 not run (yet)
  EXPECT_NE(running.out.find("job 77: 2 tasks still queued or running"), std::string::npos)
      << running.out;
  fs::remove(dir + "/bin/running");
  // --emit writes a job of the lost row alone (and the failed one: --retry-failed).
  const testing::CommandResult emit =
      run_hapvox_env(path, sweep + slurm + " --emit slurm --retry-failed");
  ASSERT_EQ(emit.exit_code, 0) << emit.err;
  EXPECT_FALSE(fs::exists(slurm + "/slurm.job"));  // the old job's
  const std::string again = testing::read_file(slurm + "/sweep.sbatch");
  EXPECT_NE(again.find("\n#SBATCH --array=0-0\n"), std::string::npos) << again;
  EXPECT_NE(again.find("rows=(\n  4:" + lost + ",6:" + summary[6].at("id") + "\n)\n"),
            std::string::npos)
      << again;
  const testing::CommandResult missing = run_hapvox_env(path, "sweep --collect " + slurm);
  EXPECT_EQ(missing.exit_code, 102) << missing.out;
  EXPECT_NE(missing.out.find("5 done, 1 failed, 1 not run"), std::string::npos) << missing.out;
  // Submitted by hand: its tasks say which job they were.
  ASSERT_EQ(std::system((path + " sbatch " + slurm + "/sweep.sbatch > /dev/null").c_str()), 0);
  EXPECT_EQ(testing::read_file(slurm + "/slurm.job"), "78\n");
  const testing::CommandResult collected = run_hapvox_env(path, "sweep --collect " + slurm);
  EXPECT_EQ(collected.exit_code, 101) << collected.out;
  EXPECT_NE(collected.out.find("6 done, 1 failed, 0 not run"), std::string::npos) << collected.out;
  expect_same_sessions(dir + "/local/" + lost + ".h5", slurm + "/" + lost + ".h5");
}

TEST(SweepCli, OverHostsWithGnuParallelTheRowsAreTheLocalPoolsSessions) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  write_six_row_manifest(dir);
  ASSERT_EQ(run_hapvox("sweep " + dir + "/sweep.toml -o " + dir + "/local -j 2").exit_code, 0);
  // ':' is this machine to GNU parallel (no ssh); a comment and a blank line are skipped.
  std::ofstream(dir + "/hosts") << "# the lab's machines\n\n2/:\n";
  const std::string path =
      "PATH=" + fs::path(testing::hapvox_binary()).parent_path().string() + ":$PATH";
  const testing::CommandResult r = run_hapvox_env(
      path, "sweep " + dir + "/sweep.toml -o " + dir + "/hosts_out --hosts " + dir + "/hosts");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("(6 to run, over ssh hosts with GNU parallel"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("6 done, 0 failed, 0 not run"), std::string::npos) << r.out;
  const auto local = read_summary(dir + "/local/summary.csv");
  ASSERT_EQ(local.size(), 6u);
  for (const auto& row : local) {
    expect_same_sessions(dir + "/local/" + row.at("id") + ".h5",
                         dir + "/hosts_out/" + row.at("id") + ".h5");
  }
  // parallel's job log: a line per row, each on host ':' with exit 0.
  std::ifstream log(dir + "/hosts_out/parallel.log");
  std::string line;
  std::getline(log, line);  // its header
  int rows = 0;
  while (std::getline(log, line)) {
    std::vector<std::string> cells;
    std::stringstream split(line);
    for (std::string cell; std::getline(split, cell, '\t');) cells.push_back(cell);
    ASSERT_GE(cells.size(), 9u) << line;
    EXPECT_EQ(cells[1], ":") << line;
    EXPECT_EQ(cells[6], "0") << line;
    ++rows;
  }
  EXPECT_EQ(rows, 6);
}

TEST(SweepCli, BadBackendFlagsAreOneLineAndRunNoRow) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  write_six_row_manifest(dir);
  const std::string sweep = "sweep " + dir + "/sweep.toml -o " + dir + "/out";
  auto expect_error = [&](const std::string& args, const std::string& message) {
    const testing::CommandResult r = run_hapvox(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(r.err, "hapvox: error: " + message + "\n") << args;
    EXPECT_FALSE(fs::exists(dir + "/out")) << args;
  };
  expect_error(sweep + " --emit pbs", "--emit: 'pbs' is not a backend (slurm)");
  expect_error(sweep + " --wait", "--wait: needs --slurm");
  expect_error(sweep + " --slurm --time soon",
               "--time: 'soon' is not a Slurm time (MINUTES, H:MM:SS, DAYS-HOURS, DAYS-H:MM:SS)");
  expect_error(sweep + " --slurm --partition 'a b'", "--partition: 'a b' is not a partition name");
  expect_error(sweep + " --slurm --max-parallel -1",
               "--max-parallel: must lie in [0, 1e6], not -1");
  expect_error("sweep " + dir + "/sweep.toml -o '" + dir + "/o u t' --emit slurm",
               "--output: a Slurm sweep's directory may not hold spaces, quotes, '\\', '$', '`' "
               "or '%' (#SBATCH lines take one plain word)");
  expect_error("sweep " + dir + "/sweep.toml -o " + dir + "/100% --emit slurm",
               "--output: a Slurm sweep's directory may not hold spaces, quotes, '\\', '$', '`' "
               "or '%' (#SBATCH lines take one plain word)");
  expect_error(sweep + " --partition debug", "--partition: needs --slurm or --emit slurm");
  expect_error(sweep + " --rows-per-task 2", "--rows-per-task: needs --slurm or --emit slurm");
  expect_error(sweep + " --hosts " + dir + "/none", dir + "/none: cannot be read");
  std::ofstream(dir + "/hosts") << "# nobody\n";
  expect_error(sweep + " --hosts " + dir + "/hosts",
               dir + "/hosts: names no host (one [N/]host per line; ':' for this machine)");
  std::ofstream(dir + "/hosts") << "node1\nnode2; rm -rf /\n";
  expect_error(sweep + " --hosts " + dir + "/hosts",
               dir + "/hosts:2: a host line holds a quote or a shell character");
  std::ofstream(dir + "/hosts") << ":\n";
  expect_error("sweep " + dir + "/sweep.toml -o " + dir + "/{} --hosts " + dir + "/hosts",
               "--output: '" + dir + "/{}' holds a brace, which GNU parallel would replace");
  expect_error(sweep + " --slurm --hosts " + dir + "/hosts",
               "--hosts: cannot be combined with --slurm");
  expect_error(sweep + " --task-rows 0123456789abcdef",
               "--task-rows: '0123456789abcdef' is not INDEX:ID (a row of the job script)");
  expect_error(sweep + " --task-rows 9:0123456789abcdef",
               "--task-rows: row 9 is not in " + dir + "/sweep.toml (it has 6 rows)");
  const testing::CommandResult changed = run_hapvox(sweep + " --task-rows 0:0123456789abcdef");
  EXPECT_EQ(changed.exit_code, 2);
  EXPECT_EQ(
      changed.err.rfind("hapvox: error: --task-rows: row 0 (" + dir + "/sweep.toml:1) is ", 0), 0u)
      << changed.err;
  EXPECT_NE(changed.err.find(", not 0123456789abcdef: the manifest or one of its files changed "
                             "since the job was written\n"),
            std::string::npos)
      << changed.err;
  expect_error("sweep --collect " + dir,
               dir + ": is not a sweep's directory (it has no sweep.manifest)");
  expect_error("sweep --collect " + dir + " -j 2",
               "--collect: takes the directory alone (not --jobs)");
  expect_error("sweep -o " + dir + "/out", "sweep: needs a manifest (or --collect DIR)");
  // No sbatch on the PATH: one line, nothing written.
  const testing::CommandResult r = run_hapvox_env("PATH=/nothing", sweep + " --slurm");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hapvox: error: --slurm: sbatch is not on this machine's PATH (is this a Slurm "
            "login node? --emit slurm writes the script alone)\n");
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

// A row's session in a sweep's directory (ID.h5; summary.h5 is not one).
bool is_session(const fs::path& path) {
  return path.extension() == ".h5" && path.filename() != "summary.h5";
}

TEST(SweepCli, AKilledSweepRerunsOnlyItsMissingRowsAndAFailedRowIsCounted) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  // 6 rows, one of which the replay refuses (a hardening slope above E).
  std::ofstream(dir + "/sweep.toml") << "traces = ['press16.csv', 'press24.csv', 'press32.csv']\n"
                                        "volumes = ['block:dims=48']\n"
                                        "[options]\n"
                                        "tool-diameter-mm = [6, 8]\n"
                                        "[[row]]\n"
                                        "trace = 'press24.csv'\n"
                                        "volume = 'block:dims=48'\n"
                                        "options = { plastic = true, "
                                        "elastoplastic-modulus-pa = 2e5 }\n";
  const std::string out = dir + "/out";
  const std::string start = testing::hapvox_binary() + " sweep " + dir + "/sweep.toml -o " + out +
                            " -j 1 > " + dir + "/first.txt 2>&1 & echo $! > " + dir + "/pid";
  ASSERT_EQ(std::system(("sh -c '" + start + "'").c_str()), 0);
  // Killed once two rows are done.
  auto done_rows = [&] {
    int n = 0;
    if (!fs::exists(out)) return 0;
    for (const auto& e : fs::directory_iterator(out)) n += is_session(e.path());
    return n;
  };
  for (int i = 0; i < 3000 && done_rows() < 2; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const pid_t pid = std::stoi(testing::read_file(dir + "/pid"));
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  for (int i = 0; i < 1000 && ::kill(pid, 0) == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const int done_first = done_rows();
  ASSERT_GE(done_first, 2);
  ASSERT_LT(done_first, 6);  // one row at a time: it had rows left
  std::map<std::string, fs::file_time_type> first_sessions;
  for (const auto& e : fs::directory_iterator(out)) {
    if (is_session(e.path())) first_sessions[e.path().string()] = e.last_write_time();
    EXPECT_NE(e.path().extension(), ".partial") << e.path();
  }
  const auto killed = read_summary(out + "/summary.csv");
  ASSERT_EQ(killed.size(), 7u);  // written on the way out: what was done, what was not

  const testing::CommandResult again = run_hapvox("sweep " + dir + "/sweep.toml -o " + out);
  EXPECT_EQ(again.exit_code, 101) << again.out << again.err;  // one row failed
  const std::size_t to_run = 7 - static_cast<std::size_t>(done_first);
  EXPECT_NE(again.out.find("7 rows -> " + out + " (" + std::to_string(to_run) + " to run"),
            std::string::npos)
      << again.out;
  EXPECT_NE(again.out.find("6 done, 1 failed, 0 not run"), std::string::npos) << again.out;
  for (const auto& [path, time] : first_sessions) {
    EXPECT_EQ(fs::last_write_time(path), time) << path << " was run again";
  }
  const auto summary = read_summary(out + "/summary.csv");
  ASSERT_EQ(summary.size(), 7u);
  EXPECT_EQ(summary.back().at("status"), "failed");
  EXPECT_NE(summary.back().at("error").find("--elastoplastic-modulus-pa: must lie in [0, E)"),
            std::string::npos)
      << summary.back().at("error");
  // A third run has nothing to run and still says a row failed; --retry-failed runs it.
  const testing::CommandResult third = run_hapvox("sweep " + dir + "/sweep.toml -o " + out);
  EXPECT_EQ(third.exit_code, 101);
  EXPECT_NE(third.out.find("(0 to run"), std::string::npos) << third.out;
  const testing::CommandResult retry =
      run_hapvox("sweep " + dir + "/sweep.toml -o " + out + " --retry-failed");
  EXPECT_EQ(retry.exit_code, 101);
  EXPECT_NE(retry.out.find("(1 to run"), std::string::npos) << retry.out;
}

// The rows' commands (DIR/ID.cmd) a dry run of `manifest` writes: their IDs.
std::set<std::string> dry_run_ids(const std::string& manifest, const std::string& out) {
  EXPECT_EQ(run_hapvox("sweep " + manifest + " -o " + out + " --dry-run").exit_code, 0);
  std::set<std::string> ids;
  for (const auto& e : fs::directory_iterator(out)) {
    if (e.path().extension() == ".cmd") ids.insert(e.path().stem().string());
  }
  return ids;
}

TEST(SweepCli, ARowsIdFollowsTheDataFileItsVolumesHeaderNames) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  std::ofstream(dir + "/v.nhdr") << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\n"
                                    "encoding: raw\ndata file: v.raw\n";
  std::ofstream(dir + "/v.raw") << std::string(512, '\x80');
  std::ofstream(dir + "/sweep.toml") << "traces = ['press16.csv']\nvolumes = ['v.nhdr']\n";
  const std::set<std::string> first = dry_run_ids(dir + "/sweep.toml", dir + "/a");
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(dry_run_ids(dir + "/sweep.toml", dir + "/b"), first);  // the same files
  // One voxel of the data file changed, the header not: another replay, another ID.
  std::ofstream(dir + "/v.raw") << std::string(511, '\x80') << '\x81';
  const std::set<std::string> second = dry_run_ids(dir + "/sweep.toml", dir + "/c");
  ASSERT_EQ(second.size(), 1u);
  EXPECT_NE(*second.begin(), *first.begin());
}

TEST(SweepCli, ABadManifestIsOneLineNamingItsLineAndRunsNoRow) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  auto expect_error = [&](const std::string& manifest, const std::string& message) {
    std::ofstream(dir + "/m.toml") << manifest;
    const testing::CommandResult r = run_hapvox("sweep " + dir + "/m.toml -o " + dir + "/out");
    EXPECT_EQ(r.exit_code, 2) << manifest;
    EXPECT_EQ(r.err, "hapvox: error: " + dir + "/m.toml:" + message + "\n") << manifest;
    EXPECT_FALSE(fs::exists(dir + "/out")) << manifest;
  };
  const std::string grid = "traces = ['press16.csv']\nvolumes = ['block:dims=48']\n";
  expect_error(grid + "tools = [4]\n",
               "3: unknown key 'tools' (expected traces, volumes, models, materials, options, "
               "[[row]])");
  expect_error("traces = ['none.csv']\nvolumes = ['block:dims=48']\n",
               "1: trace '" + dir + "/none.csv' is not a file");
  expect_error("traces = ['press16.csv']\nvolumes = ['none.nrrd']\n",
               "1: volume '" + dir + "/none.nrrd' is not a file or a generator");
  expect_error(grid + "materials = ['soft.toml']\n",
               "1: materials '" + dir + "/soft.toml' is not a file");
  expect_error(grid + "[options]\ntool-diameter-mm = ['big']\n",
               "1: as replay flags: Could not convert: --tool-diameter-mm = big");
  // Out of its option's range: found when the sweep is planned, not when the row runs.
  expect_error(grid + "[options]\nyield-stress-pa = -5\nplastic = true\n",
               "1: as replay flags: --yield-stress-pa: must lie in (0, 1e12], not -5");
  expect_error(grid + "[options]\nshake = 1\n",
               "1: as replay flags: The following arguments were not expected: 1 --shake");
  expect_error(grid + "[[row]]\ntrace = 'press16.csv'\nvolume = 'block:dims=48'\n",
               "3: the same replay as row 1 (line 1)");
  // The summary would overwrite a row's trace: refused, the trace kept.
  fs::create_directories(dir + "/here");
  fs::copy_file(dir + "/press16.csv", dir + "/here/summary.csv");
  std::ofstream(dir + "/here/m.toml") << "traces = ['summary.csv']\nvolumes = ['block:dims=48']\n";
  const testing::CommandResult r = run_hapvox("sweep " + dir + "/here/m.toml -o " + dir + "/here");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hapvox: error: " + dir +
                       "/here/summary.csv: --output would overwrite the "
                       "input trace " +
                       dir + "/here/summary.csv\n");
  EXPECT_EQ(testing::read_file(dir + "/here/summary.csv"),
            testing::read_file(dir + "/press16.csv"));
}

}  // namespace
}  // namespace hapvox
