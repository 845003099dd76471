// hapvox sweep MANIFEST -o DIR [-j N] [--retry-failed] [--dry-run]: every replay a manifest
// describes (haptics/sweep_manifest.h), each as `hapvox replay ... -o ID.h5` run in DIR by
// a local pool of processes (tools/sweep_pool.h), then DIR/summary.csv
// (tools/sweep_summary.h). docs/sweeps.md.
//
// A row is done when DIR/ID.h5 exists (a replay writes ID.h5.partial and renames it only
// once whole), failed when DIR/ID.failed does; a rerun runs only the rows that are neither
// (a killed sweep's), and --retry-failed the failed ones again. DIR/ID.cmd is each row's
// command (run it in DIR to get the same session), DIR/ID.log its output.
// Exit 0 when every row is done, 2 for a bad manifest or flag (before any row runs),
// 100 + the number of failed rows (at most 199) otherwise, 130 when interrupted.

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <thread>

#include "engine/errors.h"
#include "engine/text_file.h"
#include "haptics/sweep_manifest.h"
#include "tools/cli.h"
#include "tools/replay_command.h"
#include "tools/sweep_pool.h"
#include "tools/sweep_summary.h"

namespace hapvox::cli {
namespace {

namespace fs = std::filesystem;

struct SweepFlags {
  std::string manifest;
  std::string output_dir;
  int jobs = 0;  // 0: the number of cores
  bool retry_failed = false;
  bool dry_run = false;
};

std::string at(const haptics::SweepManifest& m, const haptics::SweepRow& row) {
  return m.source + ":" + std::to_string(row.line);
}

// What each row reads exists, and its flags parse as `hapvox replay`'s: InputError naming
// the manifest's line, before any row runs.
void check_row(const haptics::SweepManifest& m, const haptics::SweepRow& row) {
  auto exists = [&](const std::string& path, const char* what) {
    if (!fs::is_regular_file(path)) {
      throw InputError(at(m, row), std::string(what) + " '" + path + "' is not a file");
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
    throw InputError(at(m, row), std::string("as replay flags: ") + e.what());
  }
}

std::string shell_command(const std::vector<std::string>& args) {
  std::string text = "hapvox";
  for (const std::string& a : args) text += " " + shell_quoted(a);
  return text;
}

// The last line of a failed row's output that says something.
std::string last_line(const std::string& log_path) {
  std::ifstream in(log_path);
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  return last;
}

[[noreturn]] void exit_with(int code) {
  std::fflush(stdout);
  std::fflush(stderr);
  std::_Exit(code);
}

void run_sweep(const SweepFlags& f) {
  // Everything checked before a row runs or DIR is made.
  if (f.output_dir.empty()) throw InputError("--output", "a directory is required");
  if (fs::exists(f.output_dir) && !fs::is_directory(f.output_dir)) {
    throw InputError(f.output_dir, "exists and is not a directory");
  }
  if (f.jobs < 0) throw InputError("-j", "must be at least 1 (0: one per core)");
  const haptics::SweepManifest manifest = haptics::read_sweep_manifest(f.manifest);
  std::vector<std::string> ids;
  std::map<std::string, std::size_t> first_with_id;
  for (std::size_t i = 0; i < manifest.rows.size(); ++i) {
    const haptics::SweepRow& row = manifest.rows[i];
    check_row(manifest, row);
    ids.push_back(haptics::sweep_row_id(row));
    const auto [it, inserted] = first_with_id.emplace(ids.back(), i);
    if (!inserted) {
      throw InputError(at(manifest, row), "the same replay as row " +
                                              std::to_string(it->second + 1) + " (line " +
                                              std::to_string(manifest.rows[it->second].line) + ")");
    }
  }
  // The summary may not land on an input (a row's trace named summary.csv in DIR).
  std::vector<InputPath> inputs = {{f.manifest, "manifest"}};
  for (const haptics::SweepRow& row : manifest.rows) {
    inputs.push_back({row.trace, "trace"});
    for (const InputPath& input : volume_inputs(row.volume)) inputs.push_back(input);
    if (!row.materials.empty()) inputs.push_back({row.materials, "materials file"});
  }
  check_outputs_spare_inputs({{(fs::path(f.output_dir) / "summary.csv").string(), "--output", ""}},
                             inputs);
  const int parallel =
      f.jobs > 0 ? f.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  fs::create_directories(f.output_dir);
  const std::string dir = fs::absolute(f.output_dir).lexically_normal().string();
  auto file = [&](std::size_t i, const char* ext) { return dir + "/" + ids[i] + ext; };

  // Where each row stands.
  std::vector<SweepOutcome> outcomes(manifest.rows.size());
  std::vector<std::size_t> to_run;
  std::size_t done_before = 0, failed_before = 0;
  for (std::size_t i = 0; i < manifest.rows.size(); ++i) {
    SweepOutcome& o = outcomes[i];
    o.id = ids[i];
    o.session = file(i, ".h5");
    if (fs::exists(o.session)) {
      o.status = "done";
      ++done_before;
    } else if (fs::exists(file(i, ".failed")) && !f.retry_failed) {
      o.status = "failed";
      o.error = engine::read_text_file(file(i, ".failed"));
      if (!o.error.empty() && o.error.back() == '\n') o.error.pop_back();
      ++failed_before;
    } else {
      o.status = "not run";
      to_run.push_back(i);
    }
  }
  std::printf(
      "sweep %s: %zu rows -> %s (%zu to run, %d at a time; %zu done before, %zu failed "
      "before%s)\n",
      f.manifest.c_str(), manifest.rows.size(), dir.c_str(), to_run.size(), parallel, done_before,
      failed_before, failed_before > 0 ? ": --retry-failed runs them" : "");
  std::vector<PoolJob> jobs;
  for (const std::size_t i : to_run) {
    PoolJob job;
    job.args = haptics::sweep_replay_arguments(manifest.rows[i], ids[i] + ".h5");
    job.working_dir = dir;
    job.log_path = file(i, ".log");
    std::ofstream(file(i, ".cmd"))
        << "cd " << shell_quoted(dir) << " && " << shell_command(job.args) << "\n";
    jobs.push_back(std::move(job));
  }
  if (f.dry_run) {
    for (const PoolJob& job : jobs) std::printf("  %s\n", shell_command(job.args).c_str());
    return;
  }

  end_session_on_signals();  // Ctrl-C or SIGTERM: the running rows stop, the summary is written
  const std::atomic<bool>& stop = *stop_request();
  const bool tty = isatty(STDERR_FILENO) != 0;
  std::size_t finished = 0, failed = 0, running = 0;
  auto progress = [&] {
    if (!tty) return;
    std::fprintf(stderr, "\rsweep: %zu/%zu rows run, %zu failed, %zu running   ", finished,
                 to_run.size(), failed, running);
  };
  run_pool(
      jobs, parallel, "hapvox", stop,
      [&](std::size_t) {
        ++running;
        progress();
      },
      [&](std::size_t j, JobStatus status) {
        const std::size_t i = to_run[j];
        SweepOutcome& o = outcomes[i];
        --running;
        fs::remove(file(i, ".h5.partial"));
        if (fs::exists(o.session)) {  // whole (renamed last), however the process ended
          o.status = "done";
          fs::remove(file(i, ".failed"));
        } else if (stop.load() && status == 128 + SIGTERM) {
          o.status = "not run";  // stopped by us: runs again next time
          return;
        } else {
          o.status = "failed";
          o.error = "exit " + std::to_string(status) + ": " + last_line(file(i, ".log"));
          std::ofstream(file(i, ".failed")) << o.error << "\n";
          ++failed;
        }
        ++finished;
        progress();
      });
  if (tty) std::fprintf(stderr, "\n");
  write_sweep_summary(dir + "/summary.csv", manifest.rows, outcomes);
  std::size_t done = 0, failed_total = 0, not_run = 0;
  for (const SweepOutcome& o : outcomes) {
    done += o.status == "done";
    failed_total += o.status == "failed";
    not_run += o.status == "not run";
  }
  std::printf("  rows             %zu done, %zu failed, %zu not run\n", done, failed_total,
              not_run);
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    if (outcomes[i].status == "failed") {
      std::printf("  failed           %s (%s): %s\n", ids[i].c_str(),
                  at(manifest, manifest.rows[i]).c_str(), outcomes[i].error.c_str());
    }
  }
  std::printf("  summary          %s/summary.csv\n", dir.c_str());
  if (stop.load()) exit_with(130);
  if (failed_total > 0) exit_with(100 + static_cast<int>(std::min<std::size_t>(failed_total, 99)));
}

}  // namespace

void add_sweep_command(CLI::App& app) {
  auto flags = std::make_shared<SweepFlags>();
  CLI::App* cmd = app.add_subcommand(
      "sweep",
      "Run every replay a TOML manifest describes (traces x volumes x models x materials x "
      "options, and explicit rows) in a local pool of processes, each into DIR/ID.h5; rerun "
      "to finish the rows not done; DIR/summary.csv at the end (docs/sweeps.md)");
  cmd->add_option("manifest", flags->manifest, "The sweep's manifest (.toml)")->required();
  cmd->add_option("--output,-o", flags->output_dir, "The sweep's directory")->required();
  cmd->add_option("-j,--jobs", flags->jobs, "Replays at once (0: one per core)")
      ->capture_default_str();
  cmd->add_flag("--retry-failed", flags->retry_failed, "Run the rows that failed before again");
  cmd->add_flag("--dry-run", flags->dry_run,
                "Print the commands of the rows to run (and write DIR/ID.cmd), run none");
  cmd->callback([flags] { run_sweep(*flags); });
}

}  // namespace hapvox::cli
