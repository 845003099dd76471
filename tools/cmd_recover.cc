// hapvox recover FILE.partial [-o FILE]: a session a killed run left (kill -9, a crash, a
// power cut) as a complete session h5py reads, holding every row it had written
// (haptics/session_recover.h). The unfinished file is left as it is.

#include <cstdio>
#include <memory>
#include <string>

#include "engine/errors.h"
#include "haptics/session_recover.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct RecoverFlags {
  std::string partial;
  std::string output;  // default: the partial's name without .partial
};

void run_recover(const RecoverFlags& f) {
  std::string output = f.output;
  if (output.empty()) {
    if (!f.partial.ends_with(".partial") || f.partial.size() == 8) {
      throw InputError(f.partial, "is not a NAME.partial file: name the output with -o");
    }
    output = f.partial.substr(0, f.partial.size() - 8);
  }
  // Written through OUTPUT.recovering: OUTPUT.partial may well be the input.
  check_output_path(output, "--output");
  if (output == f.partial) throw InputError(output, "--output would overwrite the input session");
  const haptics::RecoveredSession r = haptics::recover_session(f.partial, output);
  std::printf("recovered %s -> %s: %zu rows", f.partial.c_str(), output.c_str(), r.rows);
  if (r.rows > 0) std::printf(", t = %.3f .. %.3f s", r.first_time_s, r.last_time_s);
  std::printf(" (attribute recovered = 1; %s is left as it was)\n", f.partial.c_str());
}

}  // namespace

void add_recover_command(CLI::App& app) {
  auto flags = std::make_shared<RecoverFlags>();
  CLI::App* cmd = app.add_subcommand(
      "recover",
      "Make a session a killed run left (NAME.h5.partial) a complete session: every row it "
      "had written, readable by h5py (docs/formats.md)");
  cmd->add_option("partial", flags->partial, "The unfinished session, NAME.h5.partial")->required();
  cmd->add_option("--output,-o", flags->output,
                  "The complete session to write (default: NAME.h5; never replaces a file)");
  cmd->callback([flags] { run_recover(*flags); });
}

}  // namespace hapvox::cli
