// Sweep manifests (haptics/sweep_manifest.h): the grid expands in a fixed order with every
// combination once, explicit rows follow, paths resolve against the manifest's folder, IDs
// follow the inputs' bytes (not their names), and every mistake is one line naming the
// manifest's line.

#include "haptics/sweep_manifest.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <string>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

using Options = std::vector<std::pair<std::string, std::string>>;

TEST(SweepManifest, TheGridExpandsEveryCombinationOnceTheLastOptionFastest) {
  const SweepManifest m = parse_sweep_manifest(
      "traces = ['a.csv', 'b.csv']\n"
      "volumes = ['block', 'ct.nrrd']\n"
      "materials = ['', 'soft.toml']\n"
      "[options]\n"
      "tool-diameter-mm = [4, 8.5]\n"
      "plastic = [false, true]\n"
      "youngs-modulus-pa = 2e5\n"
      "[[row]]\n"
      "trace = '/abs/c.csv'\n"
      "volume = 'four-spheres:dims=32'\n"
      "model = 'fem'\n"
      "options = { interaction = 'grab' }\n",
      "m.toml", "/sweeps");
  // 2 traces x 2 volumes x 1 model x 2 materials x (2 x 2 x 1) options, then the row.
  ASSERT_EQ(m.rows.size(), 2u * 2 * 2 * 4 + 1);
  const SweepRow& first = m.rows.front();
  EXPECT_EQ(first.trace, "/sweeps/a.csv");
  EXPECT_EQ(first.volume, "block");  // a generator stays a spec
  EXPECT_EQ(first.model, "voxel");
  EXPECT_EQ(first.materials, "");
  EXPECT_EQ(first.line, 1);
  // Options sorted by name; false is no flag, true the bare flag, numbers exact and short.
  EXPECT_EQ(first.options, (Options{{"tool-diameter-mm", "4"}, {"youngs-modulus-pa", "200000"}}));
  // By name, the last varying fastest: the tool, then plastic.
  EXPECT_EQ(m.rows[1].options,
            (Options{{"tool-diameter-mm", "8.5"}, {"youngs-modulus-pa", "200000"}}));
  EXPECT_EQ(m.rows[2].options,
            (Options{{"plastic", ""}, {"tool-diameter-mm", "4"}, {"youngs-modulus-pa", "200000"}}));
  EXPECT_EQ(m.rows[4].materials, "/sweeps/soft.toml");
  EXPECT_EQ(m.rows[8].volume, "/sweeps/ct.nrrd");
  EXPECT_EQ(m.rows[16].trace, "/sweeps/b.csv");
  std::set<std::string> distinct;
  for (std::size_t i = 0; i + 1 < m.rows.size(); ++i) {
    const SweepRow& r = m.rows[i];
    std::string key = r.trace + "|" + r.volume + "|" + r.materials;
    for (const auto& [k, v] : r.options) key += "|" + k + "=" + v;
    distinct.insert(key);
  }
  EXPECT_EQ(distinct.size(), m.rows.size() - 1);
  const SweepRow& explicit_row = m.rows.back();
  EXPECT_EQ(explicit_row.trace, "/abs/c.csv");
  EXPECT_EQ(explicit_row.model, "fem");
  EXPECT_EQ(explicit_row.options, (Options{{"interaction", "grab"}}));
  EXPECT_EQ(explicit_row.line, 8);
  EXPECT_EQ(sweep_replay_arguments(m.rows[2], "x.h5"),
            (std::vector<std::string>{"replay", "/sweeps/a.csv", "--volume", "block", "--model",
                                      "voxel", "--plastic", "--tool-diameter-mm", "4",
                                      "--youngs-modulus-pa", "200000", "-q", "-o", "x.h5"}));
}

TEST(SweepManifest, AnIdFollowsTheInputsBytesNotTheirNames) {
  const std::string dir = testing::scratch_dir();
  std::ofstream(dir + "/a.csv") << "t,x,y,z\n0,1,2,3\n";
  std::ofstream(dir + "/same.csv") << "t,x,y,z\n0,1,2,3\n";
  std::ofstream(dir + "/b.csv") << "t,x,y,z\n0,1,2,4\n";
  SweepFileDigests digests;
  auto id_of = [&](const SweepRow& row, const std::vector<std::string>& volume_files = {}) {
    return sweep_row_id(row, volume_files, digests);
  };
  SweepRow row;
  row.trace = dir + "/a.csv";
  row.volume = "block:dims=32";
  const std::string id = id_of(row);
  EXPECT_EQ(id.size(), 16u);
  EXPECT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_EQ(id_of(row), id);  // deterministic
  SweepRow renamed = row;
  renamed.trace = dir + "/same.csv";
  EXPECT_EQ(id_of(renamed), id);  // the same bytes elsewhere
  SweepRow changed = row;
  changed.trace = dir + "/b.csv";
  EXPECT_NE(id_of(changed), id);  // one byte of the trace
  SweepRow other_volume = row;
  other_volume.volume = "block:dims=33";
  EXPECT_NE(id_of(other_volume), id);
  SweepRow with_option = row;
  with_option.options = {{"plastic", ""}};
  EXPECT_NE(id_of(with_option), id);
  SweepRow fem = row;
  fem.model = "fem";
  EXPECT_NE(id_of(fem), id);
  // A value cannot pass for a flag's name: --a b is not --ab.
  SweepRow split = row, joined = row;
  split.options = {{"a", "b"}};
  joined.options = {{"ab", ""}};
  EXPECT_NE(id_of(split), id_of(joined));
  SweepRow missing = row;
  missing.trace = dir + "/none.csv";
  EXPECT_EQ(testing::input_error_of([&] { id_of(missing); }), dir + "/none.csv: cannot be read");
}

TEST(SweepManifest, AVolumesIdCoversEveryFileItReadsAndTheOptionsAfterItsPath) {
  const std::string dir = testing::scratch_dir();
  std::ofstream(dir + "/t.csv") << "t,x,y,z\n0,1,2,3\n";
  std::ofstream(dir + "/ct.nhdr") << "NRRD0004\ndata file: ct.raw\n";
  std::ofstream(dir + "/ct.raw") << std::string(64, '\0');
  std::ofstream(dir + "/copy.nhdr") << "NRRD0004\ndata file: ct.raw\n";
  SweepFileDigests digests;
  SweepRow row;
  row.trace = dir + "/t.csv";
  row.volume = dir + "/ct.nhdr";
  const std::vector<std::string> files = {dir + "/ct.nhdr", dir + "/ct.raw"};
  const std::string id = sweep_row_id(row, files, digests);
  SweepRow copy = row;
  copy.volume = dir + "/copy.nhdr";
  EXPECT_EQ(sweep_row_id(copy, {dir + "/copy.nhdr", dir + "/ct.raw"}, digests), id);
  // One voxel of the data file changed: another ID (with digests read afresh).
  std::ofstream(dir + "/ct.raw") << std::string(63, '\0') << '\1';
  SweepFileDigests fresh;
  EXPECT_NE(sweep_row_id(row, files, fresh), id);
  // A raw file's options after its path count; its path does not.
  SweepRow raw = row, other_dims = row, moved = row;
  raw.volume = dir + "/ct.raw:dims=4,4,4";
  other_dims.volume = dir + "/ct.raw:dims=8,4,2";
  moved.volume = dir + "/copy.raw:dims=4,4,4";
  std::ofstream(dir + "/copy.raw") << std::string(63, '\0') << '\1';
  const std::string raw_id = sweep_row_id(raw, {dir + "/ct.raw"}, fresh);
  EXPECT_NE(sweep_row_id(other_dims, {dir + "/ct.raw"}, fresh), raw_id);
  EXPECT_EQ(sweep_row_id(moved, {dir + "/copy.raw"}, fresh), raw_id);
}

TEST(SweepManifest, MistakesAreOneLineNamingTheManifestsLine) {
  auto error = [](const std::string& text) {
    try {
      parse_sweep_manifest(text, "m.toml", "");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\nvolume = 'x'\n"),
            "m.toml:3: unknown key 'volume' (expected traces, volumes, models, materials, "
            "options, [[row]])");
  EXPECT_EQ(error("traces = ['a.csv']\n"), "m.toml:1: a grid of traces needs volumes too");
  EXPECT_EQ(error("traces = []\nvolumes = ['block']\n"),
            "m.toml:1: traces must not be an empty list");
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = [3]\n"), "m.toml:2: volumes must be a string");
  // (Found by the fuzz target: an empty volume passed.) Only materials may be "" (none).
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block', '']\n"),
            "m.toml:2: volumes must not be empty");
  EXPECT_EQ(error("[[row]]\ntrace = ''\nvolume = 'block'\n"), "m.toml:2: trace must not be empty");
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\nmodels = ['fem', 'mesh']\n"),
            "m.toml:3: unknown model 'mesh' (voxel or fem)");
  // (Found by the fuzz target: a TOML escape put a line break in the quoted name.)
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\nmodels = [\"me\\nsh\\t\"]\n"),
            "m.toml:3: unknown model 'me\\x0Ash\\x09' (voxel or fem)");
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\n\"a\\rb\" = 1\n"),
            "m.toml:3: unknown key 'a\\x0Db' (expected traces, volumes, models, materials, "
            "options, [[row]])");
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\n[options]\noutput = 'x.h5'\n"),
            "m.toml:4: option 'output' is set by the sweep (each row's inputs and output)");
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\n[options]\n--plastic = true\n"),
            "m.toml:4: option '--plastic': name replay's flags without their dashes");
  EXPECT_EQ(error("traces = ['a.csv']\nvolumes = ['block']\n[options]\nfit = [[1]]\n"),
            "m.toml:4: option fit must list plain values");
  EXPECT_EQ(error("[[row]]\ntrace = 'a.csv'\n"), "m.toml:1: [[row]] has no volume");
  EXPECT_EQ(error("[[row]]\ntrace = 'a.csv'\nvolume = 'block'\nspeed = 3\n"),
            "m.toml:4: unknown key 'speed' in [[row]] (expected trace, volume, model, "
            "materials, options)");
  EXPECT_EQ(error("[[row]]\ntrace = 'a.csv'\nvolume = 'block'\noptions = { tool-diameter-mm = "
                  "[4, 8] }\n"),
            "m.toml:4: option tool-diameter-mm: a row takes one value (lists belong to the grid)");
  EXPECT_EQ(error("# nothing\n"), "m.toml:1: no replay: give traces and volumes, or [[row]]s");
  const std::string syntax = error("traces = ['a.csv'\n");
  EXPECT_EQ(syntax.rfind("m.toml:", 0), 0u) << syntax;
  EXPECT_EQ(syntax.find('\n'), std::string::npos) << syntax;
}

TEST(SweepManifest, RowsPastTheLimitAreCountedNotMade) {
  // A 31 kB grid of a billion rows grew past 8 GB, --dry-run or not.
  std::string list;
  for (int i = 0; i < 1000; ++i) list += (i ? ", " : "") + std::to_string(i);
  const std::string grid =
      "traces = ['a.csv', 'b.csv']\nvolumes = ['block']\n"
      "[options]\ntool-diameter-mm = [" +
      list +
      "]\n"
      "youngs-modulus-pa = [" +
      list +
      "]\n"
      "poisson = [" +
      list + "]\n";
  EXPECT_EQ(hapvox::testing::input_error_of([&] { parse_sweep_manifest(grid, "m.toml", ""); }),
            "m.toml:1: describes 2000000000 replays, over the limit of 100000 rows (raise it "
            "with --max-sweep-rows)");
  engine::InputLimits& limits = engine::input_limits();
  const engine::InputLimits saved = limits;
  limits.max_sweep_rows = 3;  // explicit rows count too
  const std::string row = "[[row]]\ntrace = 'a.csv'\nvolume = 'block'\n";
  EXPECT_EQ(parse_sweep_manifest(row + row + row, "m.toml", "").rows.size(), 3u);
  EXPECT_EQ(hapvox::testing::input_error_of(
                [&] { parse_sweep_manifest(row + row + row + row, "m.toml", ""); }),
            "m.toml:1: describes 4 replays, over the limit of 3 rows (raise it with "
            "--max-sweep-rows)");
  limits = saved;
}

TEST(SweepManifest, NestingPastTheDepthLimitIsRefusedBeforeTomlReadsIt) {
  // 100,000 dotted key parts overflowed the stack inside toml++.
  std::string key = "a";
  for (int i = 0; i < 100000; ++i) key += ".a";
  EXPECT_EQ(hapvox::testing::input_error_of([&] {
              parse_sweep_manifest("traces = ['a.csv']\n" + key + " = 1\n", "m.toml", "");
            }),
            "m.toml:2: nests 100001 levels deep (tables, dotted keys, arrays and inline tables), "
            "over the limit of 64");
}

}  // namespace
}  // namespace hapvox::haptics
