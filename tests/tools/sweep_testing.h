#pragma once
// What the sweep tests share (sweep_cli_test.cc, and sweep_slurm_check.cc, which CI runs
// against a real one-node Slurm): the traces and clays of a 12-row sweep, the summary as
// read back, and the comparison of two sessions of the same replay.

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "haptics/session.h"
#include "test_data.h"

namespace hapvox::testing {

// Three presses into the clay block (block:dims=48: its top at z = 23.5) at three places.
inline void write_traces(const std::string& dir) {
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

inline std::vector<std::map<std::string, std::string>> read_summary(const std::string& path) {
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
inline int run_row_command_in(const std::string& cmd_file, const std::string& dir) {
  const std::string cmd = read_file(cmd_file);
  const std::size_t at = cmd.find("&& hapvox ");
  EXPECT_NE(at, std::string::npos) << cmd;
  const std::string args = cmd.substr(at + 10, cmd.find_last_not_of('\n') - at - 9);
  // argv[0] "hapvox", as the sweep runs it: the session records its command line.
  const std::string line =
      "cd '" + dir + "' && exec -a hapvox " + hapvox_binary() + " " + args + " > /dev/null 2>&1";
  return std::system(("bash -c " + std::string("\"") + line + "\"").c_str());
}

// Every dataset and attribute equal, but those that time the computer (compute_ns, timing/*,
// summary_compute_*).
inline void expect_same_sessions(const std::string& a, const std::string& b) {
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

// The 12-row manifest of the tests: 3 traces x 2 clays x 2 tool sizes (write_traces first).
inline void write_twelve_row_manifest(const std::string& dir) {
  std::ofstream(dir + "/sweep.toml") << "traces = ['press16.csv', 'press24.csv', 'press32.csv']\n"
                                        "volumes = ['block:dims=48']\n"
                                        "materials = ['"
                                     << source_path("data/clay_block.toml")
                                     << "', 'stiff.toml']\n"
                                        "[options]\n"
                                        "tool-diameter-mm = [6, 8]\n";
}

}  // namespace hapvox::testing
