// `hapvox bench sculpt` end to end on a small block: both strokes' rows, every event's
// deletion read by a later tick, the lockstep reference reading each the very next tick.
// No speed assertions: lateness and lag are the bench's to report, not a unit test's.

#include <gtest/gtest.h>

#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.h"

namespace hapvox {
namespace {

using testing::run_hapvox;

// The table's rows by mode ("realtime", "lockstep"): column name -> field.
std::map<std::string, std::map<std::string, std::string>> read_rows(const std::string& out) {
  const std::vector<std::string> names = {"diameter", "mode",     "ticks",  "p99 lat us", "missed",
                                          "events",   "q max",    "q p99",  "q full",     "lag p50",
                                          "lag p99",  "lag max",  "lag tk", "unseen",     "backlog",
                                          "relax",    "drain ms", "peak N", "mass"};
  std::map<std::string, std::map<std::string, std::string>> rows;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream in(line);
    std::vector<std::string> fields;
    for (std::string field; in >> field;) fields.push_back(field);
    if (fields.size() != names.size() || (fields[1] != "realtime" && fields[1] != "lockstep")) {
      continue;
    }
    for (std::size_t i = 0; i < names.size(); ++i) rows[fields[1]][names[i]] = fields[i];
  }
  return rows;
}

TEST(BenchSculptCli, RealtimeAndLockstepStrokesReadEveryEventsDeletion) {
  const auto r = run_hapvox("bench sculpt --size 64 --diameters 8 --stroke-mm 10");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const auto rows = read_rows(r.out);
  ASSERT_EQ(rows.size(), 2u) << r.out;
  for (const auto& [mode, row] : rows) {
    // 0.75 s at 1 kHz: 0.2 s down, 0.5 s along, 0.1 s held.
    EXPECT_EQ(row.at("ticks"), "751") << mode;
    EXPECT_GT(std::stoi(row.at("events")), 300) << mode;
    // The hold lets the last ones through; in realtime the held tool sometimes goes on
    // yielding, and its last tick's event no tick can read.
    EXPECT_LE(std::stoi(row.at("unseen")), mode == "realtime" ? 1 : 0) << mode;
    EXPECT_EQ(row.at("q full"), "0") << mode;
    EXPECT_EQ(row.at("mass"), "exact") << mode;
    EXPECT_GE(std::stod(row.at("lag tk")), 1.0) << mode;
  }
  // Lockstep applies a tick's deletion before the next tick: one tick, every time.
  EXPECT_EQ(rows.at("lockstep").at("lag tk"), "1");
  EXPECT_EQ(rows.at("lockstep").at("missed"), "-");
}

TEST(BenchSculptCli, AStrokeTooLongForTheBlockIsOneLine) {
  const auto r = run_hapvox("bench sculpt --size 64 --diameters 40 --stroke-mm 30");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hapvox: error: --stroke-mm: a 40 mm tool's stroke of 30 mm (with 8 mm margins) "
            "leaves the 64 mm block\n");
  EXPECT_EQ(r.out, "");
}

}  // namespace
}  // namespace hapvox
