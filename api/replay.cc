// hapvox::replay and run_sweep_row: `hapvox replay`'s own code (tools/cmd_replay.cc) run with
// flags made from typed options (include/hapvox/replay.h).

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>

#include "api/internal.h"
#include "engine/errors.h"
#include "haptics/sweep_manifest.h"
#include "hapvox/replay.h"

namespace hapvox {

namespace {

/// A folder of its own under the system's temporary directory, removed with what it holds.
class TemporaryFolder {
 public:
  TemporaryFolder() {
    std::string pattern = (std::filesystem::temp_directory_path() / "hapvox-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) {
      throw InputError(pattern, "cannot make a temporary folder for the session");
    }
    path_ = pattern;
  }
  ~TemporaryFolder() {
    std::error_code error;
    std::filesystem::remove_all(path_, error);
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// Runs `hapvox ARGS` in this process, silently, and reads back the session it wrote.
Session run_replay_args(std::vector<std::string> args, const std::string& output) {
  std::unique_ptr<TemporaryFolder> temporary;
  std::string session_path = output;
  if (session_path.empty()) {
    temporary = std::make_unique<TemporaryFolder>();
    session_path = temporary->path() + "/session.h5";
  }
  args.insert(args.end(), {"-q", "-o", session_path});
  cli::ReplayFlags flags;
  const std::unique_ptr<CLI::App> parser = api::parse_replay_flags(args, flags);
  flags.print_report = false;
  cli::run_replay(flags, api::command_text(args));
  Session session = Session::open(session_path);
  if (temporary) session.forget_path();
  return session;
}

}  // namespace

Session replay(const ReplayOptions& options) {
  std::vector<std::string> args = {"replay", options.trace, "--volume", options.volume};
  for (const auto& part :
       {api::model_flags(options.model), api::intensity_flags(options.intensity), options.flags}) {
    args.insert(args.end(), part.begin(), part.end());
  }
  if (options.realtime) args.insert(args.end(), {"--realtime", "--no-rt-priority", "--no-mlock"});
  return run_replay_args(std::move(args), options.output);
}

Session run_sweep_row(const std::string& manifest, std::size_t row, const std::string& output) {
  const haptics::SweepManifest parsed = haptics::read_sweep_manifest(manifest);
  if (row >= parsed.rows.size()) {
    throw InputError(manifest, "has " + std::to_string(parsed.rows.size()) + " rows, no row " +
                                   std::to_string(row));
  }
  // The row's replay as `hapvox sweep` runs it, less its own -q -o.
  std::vector<std::string> args = haptics::sweep_replay_arguments(parsed.rows[row], "");
  args.resize(args.size() - 3);
  return run_replay_args(std::move(args), output);
}

}  // namespace hapvox
