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
  SweepRow row;
  row.trace = dir + "/a.csv";
  row.volume = "block:dims=32";
  const std::string id = sweep_row_id(row);
  EXPECT_EQ(id.size(), 16u);
  EXPECT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_EQ(sweep_row_id(row), id);  // deterministic
  SweepRow renamed = row;
  renamed.trace = dir + "/same.csv";
  EXPECT_EQ(sweep_row_id(renamed), id);  // the same bytes elsewhere
  SweepRow changed = row;
  changed.trace = dir + "/b.csv";
  EXPECT_NE(sweep_row_id(changed), id);  // one byte of the trace
  SweepRow other_volume = row;
  other_volume.volume = "block:dims=33";
  EXPECT_NE(sweep_row_id(other_volume), id);
  SweepRow with_option = row;
  with_option.options = {{"plastic", ""}};
  EXPECT_NE(sweep_row_id(with_option), id);
  SweepRow fem = row;
  fem.model = "fem";
  EXPECT_NE(sweep_row_id(fem), id);
  // A value cannot pass for a flag's name: --a b is not --ab.
  SweepRow split = row, joined = row;
  split.options = {{"a", "b"}};
  joined.options = {{"ab", ""}};
  EXPECT_NE(sweep_row_id(split), sweep_row_id(joined));
  SweepRow missing = row;
  missing.trace = dir + "/none.csv";
  EXPECT_THROW(sweep_row_id(missing), InputError);
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

}  // namespace
}  // namespace hapvox::haptics
