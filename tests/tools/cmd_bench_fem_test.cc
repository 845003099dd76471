// `hapvox bench fem` end to end on tiny meshes: the tables and goals printed, the CSV's
// counts those of the lattices it names, the JSON beside it. No speed assertions: which
// solver is faster is the bench's to report, not a unit test's.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.h"

namespace hapvox {
namespace {

using testing::read_file;
using testing::run_hapvox;
using testing::scratch_dir;

// The CSV's data rows as column name -> field, skipping the '#' machine lines.
std::vector<std::map<std::string, std::string>> read_csv(const std::string& text) {
  std::istringstream lines(text);
  std::vector<std::string> names;
  std::vector<std::map<std::string, std::string>> rows;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::istringstream in(line);
    for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
    if (line.back() == ',') fields.emplace_back();
    if (names.empty()) {
      names = fields;
      continue;
    }
    EXPECT_EQ(fields.size(), names.size()) << line;
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < names.size() && i < fields.size(); ++i) row[names[i]] = fields[i];
    rows.push_back(row);
  }
  return rows;
}

int as_int(const std::map<std::string, std::string>& row, const std::string& name) {
  return std::stoi(row.at(name));
}

TEST(BenchFemCli, TinyRunPrintsTheTablesAndWritesCountsOfTheLatticesItNames) {
  const std::string dir = scratch_dir();
  const std::string csv = dir + "/fem.csv", json = dir + "/fem.json";
  const testing::CommandResult r = run_hapvox(
      "bench fem --sizes 48,300 --nakao-vertices 27,243 --min-time-s 0.001 "
      "--repetitions 1 --csv " +
      csv + " --json " + json);
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  for (const char* text :
       {"single thread", "linear Hz", "CG Hz", "refact Hz", "corot Hz", "tick p99", "goal",
        "beat Nakao Table 1 Spheres (243 vertices): 27.6 fps",
        "tick p99 <= 20 us, 16 contact vertices"}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
  }
  ASSERT_TRUE(std::filesystem::exists(csv));
  ASSERT_TRUE(std::filesystem::exists(json));
  EXPECT_FALSE(std::filesystem::exists(csv + ".partial"));

  const auto rows = read_csv(read_file(csv));
  // Two lattices by tet count, two at Nakao's vertex counts, two conforming meshes.
  ASSERT_EQ(rows.size(), 6u) << read_file(csv);
  std::map<std::string, int> kinds;
  for (const auto& row : rows) {
    ++kinds[row.at("kind")];
    const int vertices = as_int(row, "vertices"), tets = as_int(row, "tets");
    ASSERT_GT(vertices, 0);
    ASSERT_GT(tets, 0);
    EXPECT_GT(std::stod(row.at("factor_ms")), 0.0);
    EXPECT_GT(std::stod(row.at("linear_hz")), 0.0);
    EXPECT_GT(std::stod(row.at("naive_cg_hz")), 0.0);
    EXPECT_GT(std::stod(row.at("naive_refactor_hz")), 0.0);
    EXPECT_GT(std::stod(row.at("corot_hz")), 0.0);
    EXPECT_GT(std::stod(row.at("naive_corot_hz")), 0.0);
    EXPECT_LE(std::stod(row.at("tick_p50_us")), std::stod(row.at("tick_p99_us")));
    // CG stops on its recursively updated residual (<= 1e-12); the true one is within
    // round-off of that.
    EXPECT_LE(std::stod(row.at("naive_cg_residual")), 1e-10);
    // The condensed contact forces are those of the full solve.
    EXPECT_LT(std::stod(row.at("tick_force_rel_error")), 1e-6);
    if (row.at("kind") == "spheres") {
      EXPECT_GT(std::stod(row.at("build_ms")), 0.0);
      EXPECT_EQ(as_int(row, "nx"), 0);
      continue;
    }
    const int nx = as_int(row, "nx"), ny = as_int(row, "ny"), nz = as_int(row, "nz");
    EXPECT_EQ(vertices, nx * ny * nz);
    EXPECT_EQ(tets, 6 * (nx - 1) * (ny - 1) * (nz - 1));
    // One side (z = 0) fixed: its nx x ny vertices hold all three DOFs.
    EXPECT_EQ(as_int(row, "free_dofs"), 3 * (vertices - nx * ny));
    EXPECT_EQ(as_int(row, "contact_vertices"), std::min(16, vertices - nx * ny));
    EXPECT_EQ(row.at("build_ms"), "null");
  }
  EXPECT_EQ(kinds["lattice"], 2);
  EXPECT_EQ(kinds["nakao"], 2);
  EXPECT_EQ(kinds["spheres"], 2);
  // The counts asked for: 48 tets is a 3^3 lattice; 27 vertices too; 243 -> 5 x 7 x 7.
  EXPECT_EQ(as_int(rows[0], "tets"), 48);
  EXPECT_EQ(as_int(rows[2], "vertices"), 27);
  EXPECT_EQ(as_int(rows[3], "vertices"), 245);
  EXPECT_EQ(rows[3].at("nakao_data"), "Spheres");
  EXPECT_EQ(rows[3].at("nakao_fps"), "27.6");

  const std::string j = read_file(json);
  EXPECT_NE(j.find("\"machine\""), std::string::npos);
  EXPECT_NE(j.find("\"goals\""), std::string::npos);
  std::size_t json_rows = 0;
  for (auto at = j.find("\"kind\""); at != std::string::npos; at = j.find("\"kind\"", at + 1)) {
    ++json_rows;
  }
  EXPECT_EQ(json_rows, rows.size());
}

TEST(BenchFemCli, HelpAndBadInput) {
  const testing::CommandResult help = run_hapvox("bench fem --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--nakao-vertices"), std::string::npos) << help.out;
  const testing::CommandResult bad = run_hapvox("bench fem --sizes 0");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err,
            "hapvox: error: --sizes: expected positive integers separated by commas, got '0'\n");
  const testing::CommandResult time = run_hapvox("bench fem --min-time-s 0");
  EXPECT_EQ(time.exit_code, 2);
  EXPECT_EQ(time.err, "hapvox: error: --min-time-s: must lie in (0, 3600], not 0\n");
}

}  // namespace
}  // namespace hapvox
