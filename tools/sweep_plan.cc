#include "tools/sweep_plan.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "engine/errors.h"
#include "engine/text_file.h"
#include "tools/cli.h"
#include "tools/replay_command.h"

namespace hapvox::cli {
namespace {

namespace fs = std::filesystem;

std::string at_line(const haptics::SweepManifest& m, const haptics::SweepRow& row) {
  return m.source + ":" + std::to_string(row.line);
}

// What each row reads exists, and its flags parse as `hapvox replay`'s: InputError naming
// the manifest's line, before any row runs.
void check_row(const haptics::SweepManifest& m, const haptics::SweepRow& row) {
  auto exists = [&](const std::string& path, const char* what) {
    if (!fs::is_regular_file(path)) {
      throw InputError(at_line(m, row), std::string(what) + " '" + path + "' is not a file");
    }
  };
  exists(row.trace, "trace");
  for (const InputPath& input : volume_inputs(row.volume)) exists(input.path, "volume");
  if (!row.materials.empty()) exists(row.materials, "materials");
  // The replay's own parser on the row's arguments: unknown flags and values of the wrong
  // type are the manifest's mistakes.
  CLI::App app;
  ReplayFlags flags;
  CLI::App* replay = app.add_subcommand("replay");
  add_replay_flags(replay, &flags);
  replay->add_option("--output,-o", flags.output);
  replay->add_flag("--realtime", flags.realtime);
  std::vector<std::string> args = haptics::sweep_replay_arguments(row, "row.h5");
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw InputError(at_line(m, row), std::string("as replay flags: ") + e.what());
  }
}

// Where row `i` stands in DIR.
void read_outcome(SweepPlan& plan, std::size_t i, bool retry_failed) {
  SweepOutcome& o = plan.outcomes[i];
  o.id = plan.ids[i];
  o.session = plan.file(i, ".h5");
  o.error.clear();
  if (fs::exists(o.session)) {
    o.status = "done";
  } else if (fs::exists(plan.file(i, ".failed")) && !retry_failed) {
    o.status = "failed";
    o.error = engine::read_text_file(plan.file(i, ".failed"));
    if (!o.error.empty() && o.error.back() == '\n') o.error.pop_back();
  } else {
    o.status = "not run";
  }
}

}  // namespace

std::string SweepPlan::file(std::size_t i, const char* ext) const {
  return dir + "/" + ids[i] + ext;
}

std::string SweepPlan::at(std::size_t i) const { return at_line(manifest, manifest.rows[i]); }

SweepPlan plan_sweep(const std::string& manifest_path, const std::string& output_dir,
                     bool retry_failed) {
  if (output_dir.empty()) throw InputError("--output", "a directory is required");
  if (fs::exists(output_dir) && !fs::is_directory(output_dir)) {
    throw InputError(output_dir, "exists and is not a directory");
  }
  SweepPlan plan;
  plan.manifest = haptics::read_sweep_manifest(manifest_path);
  const haptics::SweepManifest& manifest = plan.manifest;
  std::map<std::string, std::size_t> first_with_id;
  for (std::size_t i = 0; i < manifest.rows.size(); ++i) {
    const haptics::SweepRow& row = manifest.rows[i];
    check_row(manifest, row);
    plan.ids.push_back(haptics::sweep_row_id(row));
    const auto [it, inserted] = first_with_id.emplace(plan.ids.back(), i);
    if (!inserted) {
      throw InputError(at_line(manifest, row),
                       "the same replay as row " + std::to_string(it->second + 1) + " (line " +
                           std::to_string(manifest.rows[it->second].line) + ")");
    }
  }
  // The summaries may not land on an input (a row's trace named summary.csv in DIR).
  std::vector<InputPath> inputs = {{manifest_path, "manifest"}};
  for (const haptics::SweepRow& row : manifest.rows) {
    inputs.push_back({row.trace, "trace"});
    for (const InputPath& input : volume_inputs(row.volume)) inputs.push_back(input);
    if (!row.materials.empty()) inputs.push_back({row.materials, "materials file"});
  }
  check_outputs_spare_inputs({{(fs::path(output_dir) / "summary.csv").string(), "--output", ""},
                              {(fs::path(output_dir) / "summary.h5").string(), "--output", ""}},
                             inputs);
  plan.dir = fs::absolute(output_dir).lexically_normal().string();
  while (plan.dir.size() > 1 && plan.dir.back() == '/') plan.dir.pop_back();
  plan.outcomes.resize(manifest.rows.size());
  for (std::size_t i = 0; i < manifest.rows.size(); ++i) {
    read_outcome(plan, i, retry_failed);
    const std::string& status = plan.outcomes[i].status;
    if (status == "done") {
      ++plan.done_before;
    } else if (status == "failed") {
      ++plan.failed_before;
    } else {
      plan.to_run.push_back(i);
    }
  }
  return plan;
}

void keep_only(SweepPlan& plan, const std::vector<std::string>& ids, const std::string& source) {
  const std::set<std::string> wanted(ids.begin(), ids.end());
  std::set<std::string> found;
  plan.to_run.clear();
  for (std::size_t i = 0; i < plan.ids.size(); ++i) {
    if (wanted.count(plan.ids[i]) == 0) continue;
    found.insert(plan.ids[i]);
    if (plan.outcomes[i].status == "done") continue;
    if (plan.outcomes[i].status == "failed") --plan.failed_before;
    read_outcome(plan, i, /*retry_failed=*/true);
    plan.to_run.push_back(i);
  }
  for (const std::string& id : wanted) {
    if (found.count(id) == 0) {
      throw InputError(source, "row " + id + " is not in " + plan.manifest.source +
                                   " (was the manifest or one of its files changed since?)");
    }
  }
}

void write_row_commands(const SweepPlan& plan) {
  fs::create_directories(plan.dir);
  std::ofstream(plan.dir + "/sweep.manifest")
      << fs::absolute(plan.manifest.source).lexically_normal().string() << "\n";
  for (const std::size_t i : plan.to_run) {
    std::ofstream(plan.file(i, ".cmd")) << "cd " << shell_quoted(plan.dir) << " && "
                                        << shell_command(haptics::sweep_replay_arguments(
                                               plan.manifest.rows[i], plan.ids[i] + ".h5"))
                                        << "\n";
  }
}

std::string manifest_of_sweep_dir(const std::string& dir) {
  const std::string path = (fs::path(dir) / "sweep.manifest").string();
  if (!fs::is_directory(dir)) throw InputError(dir, "is not a directory");
  if (!fs::is_regular_file(path)) {
    throw InputError(dir, "is not a sweep's directory (it has no sweep.manifest)");
  }
  std::string manifest = engine::read_text_file(path);
  while (!manifest.empty() && (manifest.back() == '\n' || manifest.back() == '\r')) {
    manifest.pop_back();
  }
  if (manifest.empty()) throw InputError(path, "is empty (it names the sweep's manifest)");
  return manifest;
}

SweepCounts count_outcomes(const SweepPlan& plan) {
  SweepCounts c;
  for (const SweepOutcome& o : plan.outcomes) {
    c.done += o.status == "done";
    c.failed += o.status == "failed";
    c.not_run += o.status == "not run";
  }
  return c;
}

SweepCounts summarise_sweep(const SweepPlan& plan) {
  write_sweep_summaries(plan.dir, plan.manifest.rows, plan.outcomes);
  const SweepCounts c = count_outcomes(plan);
  std::printf("  rows             %zu done, %zu failed, %zu not run\n", c.done, c.failed,
              c.not_run);
  for (std::size_t i = 0; i < plan.outcomes.size(); ++i) {
    if (plan.outcomes[i].status == "failed") {
      std::printf("  failed           %s (%s): %s\n", plan.ids[i].c_str(), plan.at(i).c_str(),
                  plan.outcomes[i].error.c_str());
    }
  }
  std::printf("  summary          %s/summary.csv, %s/summary.h5\n", plan.dir.c_str(),
              plan.dir.c_str());
  return c;
}

std::string shell_command(const std::vector<std::string>& args) {
  std::string text = "hapvox";
  for (const std::string& a : args) text += " " + shell_quoted(a);
  return text;
}

}  // namespace hapvox::cli
