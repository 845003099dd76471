#include "tools/sweep_plan.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "engine/errors.h"
#include "engine/text_file.h"
#include "engine/volume_io.h"
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
  const std::vector<InputPath> volume = volume_inputs(row.volume);
  if (volume.empty() && !engine::is_generator_spec(row.volume)) {
    throw InputError(at_line(m, row), "volume '" + row.volume + "' is not a file or a generator");
  }
  for (const InputPath& input : volume) exists(input.path, "volume");
  if (!row.materials.empty()) exists(row.materials, "materials");
  // The replay's own parser on the row's arguments: unknown flags, values of the wrong type
  // and values out of their option's range are the manifest's mistakes.
  CLI::App app;
  ReplayFlags flags;
  CLI::App* replay = app.add_subcommand("replay");
  add_replay_flags(replay, &flags);
  replay->add_option("--output,-o", flags.output);
  replay->add_flag("--realtime", flags.realtime);
  check_numeric_options(app);
  std::vector<std::string> args = haptics::sweep_replay_arguments(row, "row.h5");
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw InputError(at_line(m, row), std::string("as replay flags: ") + e.what());
  } catch (const InputError& e) {
    throw InputError(at_line(m, row), "as replay flags: " + e.source() + ": " + e.problem());
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

namespace {

// The manifest read and DIR made absolute; no row checked yet.
SweepPlan start_plan(const std::string& manifest_path, const std::string& output_dir) {
  if (output_dir.empty()) throw InputError("--output", "a directory is required");
  if (fs::exists(output_dir) && !fs::is_directory(output_dir)) {
    throw InputError(output_dir, "exists and is not a directory");
  }
  SweepPlan plan;
  plan.manifest = haptics::read_sweep_manifest(manifest_path);
  plan.dir = fs::absolute(output_dir).lexically_normal().string();
  while (plan.dir.size() > 1 && plan.dir.back() == '/') plan.dir.pop_back();
  plan.ids.resize(plan.manifest.rows.size());
  plan.outcomes.resize(plan.manifest.rows.size());
  return plan;
}

// Row `i` checked, and its ID.
std::string checked_row_id(const SweepPlan& plan, std::size_t i,
                           haptics::SweepFileDigests& digests) {
  const haptics::SweepRow& row = plan.manifest.rows[i];
  check_row(plan.manifest, row);
  std::vector<std::string> volume_files;
  for (const InputPath& input : volume_inputs(row.volume)) volume_files.push_back(input.path);
  return haptics::sweep_row_id(row, volume_files, digests);
}

}  // namespace

SweepPlan plan_sweep(const std::string& manifest_path, const std::string& output_dir,
                     bool retry_failed) {
  SweepPlan plan = start_plan(manifest_path, output_dir);
  const haptics::SweepManifest& manifest = plan.manifest;
  std::map<std::string, std::size_t> first_with_id;
  haptics::SweepFileDigests digests;  // each file read once
  for (std::size_t i = 0; i < manifest.rows.size(); ++i) {
    plan.ids[i] = checked_row_id(plan, i, digests);
    const auto [it, inserted] = first_with_id.emplace(plan.ids[i], i);
    if (!inserted) {
      throw InputError(plan.at(i), "the same replay as row " + std::to_string(it->second + 1) +
                                       " (line " + std::to_string(manifest.rows[it->second].line) +
                                       ")");
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

std::vector<TaskRow> parse_task_rows(const std::string& text) {
  std::vector<TaskRow> rows;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const std::size_t colon = item.find(':');
    TaskRow row;
    const char* end = item.data() + (colon == std::string::npos ? 0 : colon);
    const auto [ptr, error] = std::from_chars(item.data(), end, row.index);
    if (colon == std::string::npos || colon == 0 || error != std::errc() || ptr != end ||
        item.size() != colon + 17 ||
        item.find_first_not_of("0123456789abcdef", colon + 1) != std::string::npos) {
      throw InputError("--task-rows", "'" + item + "' is not INDEX:ID (a row of the job script)");
    }
    row.id = item.substr(colon + 1);
    rows.push_back(row);
  }
  if (rows.empty()) throw InputError("--task-rows", "names no row");
  return rows;
}

std::string task_rows_text(const SweepPlan& plan, std::size_t from, std::size_t to) {
  std::string text;
  for (std::size_t k = from; k < to; ++k) {
    const std::size_t i = plan.to_run[k];
    text += (k > from ? "," : "") + std::to_string(i) + ":" + plan.ids[i];
  }
  return text;
}

SweepPlan plan_task(const std::string& manifest_path, const std::string& output_dir,
                    const std::vector<TaskRow>& rows) {
  SweepPlan plan = start_plan(manifest_path, output_dir);
  haptics::SweepFileDigests digests;
  for (const TaskRow& task_row : rows) {
    if (task_row.index >= plan.manifest.rows.size()) {
      throw InputError("--task-rows", "row " + std::to_string(task_row.index) + " is not in " +
                                          plan.manifest.source + " (it has " +
                                          std::to_string(plan.manifest.rows.size()) + " rows)");
    }
    const std::string id = checked_row_id(plan, task_row.index, digests);
    if (id != task_row.id) {
      throw InputError("--task-rows", "row " + std::to_string(task_row.index) + " (" +
                                          plan.at(task_row.index) + ") is " + id + ", not " +
                                          task_row.id +
                                          ": the manifest or one of its files changed since "
                                          "the job was written");
    }
    plan.ids[task_row.index] = id;
    read_outcome(plan, task_row.index, /*retry_failed=*/true);
    if (plan.outcomes[task_row.index].status == "done") {
      ++plan.done_before;
    } else {
      plan.to_run.push_back(task_row.index);
    }
  }
  return plan;
}

SweepDirLock::SweepDirLock(const std::string& dir) {
  fs::create_directories(dir);
  const std::string path = dir + "/sweep.lock";
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw InputError(path, "cannot be opened");
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    throw InputError(dir, "another hapvox sweep is running in it (it holds sweep.lock)");
  }
}

SweepDirLock::~SweepDirLock() {
  if (fd_ >= 0) ::close(fd_);  // the lock goes with the descriptor
}

void refresh_outcomes(SweepPlan& plan) {
  for (std::size_t i = 0; i < plan.ids.size(); ++i) read_outcome(plan, i, /*retry_failed=*/false);
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
