// hapvox sweep: a 12-row manifest (3 traces x 2 materials x 2 tools) run two at a time gives
// the sessions 12 single `hapvox replay` runs give; a killed sweep reruns only its missing
// rows; a failing row is in the exit code and the summary; a bad manifest is one line
// naming its line, before any row runs.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "haptics/session.h"
#include "test_data.h"

namespace hapvox {
namespace {

namespace fs = std::filesystem;
using testing::run_hapvox;
using testing::scratch_dir;

// Three presses into the clay block (block:dims=48: its top at z = 23.5) at three places.
void write_traces(const std::string& dir) {
  for (const char* x : {"16", "24", "32"}) {
    ASSERT_EQ(run_hapvox(std::string("trace make press-release -o ") + dir + "/press" + x +
                         ".csv --start-mm " + x + ",24,29 --travel-mm 3.5 --hold-s 0.2")
                  .exit_code,
              0);
  }
  // A second clay, three times as stiff as data/clay_block.toml's.
  std::ofstream(dir + "/stiff.toml") << "[[material]]\nlabel = 0\nname = \"air\"\n"
                                        "youngs_modulus_pa = 1e3\npoisson_ratio = 0.3\n"
                                        "[[material]]\nlabel = 1\nname = \"stiff clay\"\n"
                                        "youngs_modulus_pa = 300e3\npoisson_ratio = 0.3\n"
                                        "intensity = [0.5, 1.0]\n";
}

std::vector<std::map<std::string, std::string>> read_summary(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream names(line);
  for (std::string cell; std::getline(names, cell, ',');) header.push_back(cell);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> row;
    std::size_t column = 0;
    std::string cell;
    bool quoted = false;
    for (std::size_t i = 0; i <= line.size(); ++i) {
      const char c = i < line.size() ? line[i] : ',';
      if (quoted) {
        if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
          cell += '"';
          ++i;
        } else if (c == '"') {
          quoted = false;
        } else {
          cell += c;
        }
      } else if (c == '"') {
        quoted = true;
      } else if (c == ',') {
        if (column < header.size()) row[header[column]] = cell;
        ++column;
        cell.clear();
      } else {
        cell += c;
      }
    }
    rows.push_back(row);
  }
  return rows;
}

// A row's command (DIR/ID.cmd: "cd DIR && hapvox ARGS") run as a single replay in `dir`.
int run_row_command_in(const std::string& cmd_file, const std::string& dir) {
  const std::string cmd = testing::read_file(cmd_file);
  const std::size_t at = cmd.find("&& hapvox ");
  EXPECT_NE(at, std::string::npos) << cmd;
  const std::string args = cmd.substr(at + 10, cmd.find_last_not_of('\n') - at - 9);
  // argv[0] "hapvox", as the sweep runs it: the session records its command line.
  const std::string line = "cd '" + dir + "' && exec -a hapvox " + testing::hapvox_binary() + " " +
                           args + " > /dev/null 2>&1";
  return std::system(("bash -c " + std::string("\"") + line + "\"").c_str());
}

// Every dataset and attribute equal, but those that time the computer (compute_ns, timing/*,
// summary_compute_*).
void expect_same_sessions(const std::string& a, const std::string& b) {
  const haptics::SessionInfo ia = haptics::read_session_info(a);
  const haptics::SessionInfo ib = haptics::read_session_info(b);
  ASSERT_EQ(ia.datasets, ib.datasets);
  std::size_t compared = 0;
  for (const std::string& d : ia.datasets) {
    if (d.find("compute") != std::string::npos || d.rfind("/timing", 0) == 0) continue;
    EXPECT_EQ(haptics::read_session_column(a, d), haptics::read_session_column(b, d)) << a << d;
    ++compared;
  }
  EXPECT_GT(compared, 10u);
  ASSERT_EQ(ia.attributes.size(), ib.attributes.size());
  for (std::size_t i = 0; i < ia.attributes.size(); ++i) {
    if (ia.attributes[i].first.rfind("summary_compute", 0) == 0) continue;
    EXPECT_EQ(ia.attributes[i], ib.attributes[i]) << a;
  }
}

TEST(SweepCli, TwelveRowsTwoAtATimeAreTheSessionsOfTwelveSingleReplays) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  std::ofstream(dir + "/sweep.toml") << "traces = ['press16.csv', 'press24.csv', 'press32.csv']\n"
                                        "volumes = ['block:dims=48']\n"
                                        "materials = ['"
                                     << testing::source_path("data/clay_block.toml")
                                     << "', 'stiff.toml']\n"
                                        "[options]\n"
                                        "tool-diameter-mm = [6, 8]\n";
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
}

TEST(SweepCli, AKilledSweepRerunsOnlyItsMissingRowsAndAFailedRowIsCounted) {
  const std::string dir = scratch_dir();
  write_traces(dir);
  // 6 rows, one of which the replay refuses (a negative yield stress).
  std::ofstream(dir + "/sweep.toml") << "traces = ['press16.csv', 'press24.csv', 'press32.csv']\n"
                                        "volumes = ['block:dims=48']\n"
                                        "[options]\n"
                                        "tool-diameter-mm = [6, 8]\n"
                                        "[[row]]\n"
                                        "trace = 'press24.csv'\n"
                                        "volume = 'block:dims=48'\n"
                                        "options = { plastic = true, yield-stress-pa = -5 }\n";
  const std::string out = dir + "/out";
  const std::string start = testing::hapvox_binary() + " sweep " + dir + "/sweep.toml -o " + out +
                            " -j 1 > " + dir + "/first.txt 2>&1 & echo $! > " + dir + "/pid";
  ASSERT_EQ(std::system(("sh -c '" + start + "'").c_str()), 0);
  // Killed once two rows are done.
  auto done_rows = [&] {
    int n = 0;
    if (!fs::exists(out)) return 0;
    for (const auto& e : fs::directory_iterator(out)) n += e.path().extension() == ".h5";
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
    if (e.path().extension() == ".h5") first_sessions[e.path().string()] = e.last_write_time();
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
  EXPECT_NE(summary.back().at("error").find("--yield-stress-pa: must be positive"),
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
  expect_error(grid + "materials = ['soft.toml']\n",
               "1: materials '" + dir + "/soft.toml' is not a file");
  expect_error(grid + "[options]\ntool-diameter-mm = ['big']\n",
               "1: as replay flags: Could not convert: --tool-diameter-mm = big");
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
