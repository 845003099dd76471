// hapvox report SESSION.h5 -o DIR: pictures of a session (force over time, lateness
// histogram, queue depth and relaxation work), drawn by matplotlib.
//
// Plotting is left to matplotlib (Debian's python3-matplotlib with python3-h5py) rather
// than hand-written: the script is compiled into the binary (tools/report.py) and run
// with the system python3, so the command works from any directory.

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "engine/errors.h"
#include "haptics/session.h"
#include "tools/cli.h"
#include "tools/report_script.h"

namespace hapvox::cli {
namespace {

struct ReportFlags {
  std::string session;
  std::string out_dir = ".";
  std::string python = "/usr/bin/python3";
};

void run_report(const ReportFlags& f) {
  if (!haptics::is_hdf5_file(f.session)) {
    throw InputError(f.session, std::filesystem::exists(f.session) ? "not an HDF5 session file"
                                                                   : "no such file");
  }
  check_outputs_spare_inputs({{f.out_dir, "--output", "(force|lateness|relax)\\.png"}},
                             {{f.session, "session"}});
  const haptics::SessionInfo info = haptics::read_session_info(f.session);
  if (info.rows == 0) throw InputError(f.session, "the session has no rows");
  const std::string probe =
      shell_quoted(f.python) + " -c 'import matplotlib, h5py, numpy' 2>/dev/null";
  if (std::system(probe.c_str()) != 0) {
    throw InputError("--python", f.python +
                                     " cannot import matplotlib, h5py and numpy (install "
                                     "python3-matplotlib python3-h5py; scripts/setup.sh does)");
  }
  // The pictures' directory (and its parents) is made when missing, as `-o plots/` on a
  // fresh clone expects; only once everything else has been checked.
  std::error_code error;
  std::filesystem::create_directories(f.out_dir, error);
  if (!std::filesystem::is_directory(f.out_dir)) {
    throw InputError(f.out_dir, "cannot create the output directory" +
                                    (error ? " (" + error.message() + ")" : std::string()));
  }
  const int status = run_python_script(f.python, kReportScript, "report", {f.session, f.out_dir});
  if (status != 0) {
    throw InputError(f.session,
                     "plotting failed (python exit status " + std::to_string(status) + ")");
  }
}

}  // namespace

void add_report_command(CLI::App& app) {
  auto flags = std::make_shared<ReportFlags>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Draw a session: force.png, lateness.png (realtime) and relax.png (plastic) into a "
      "directory");
  cmd->add_option("session", flags->session, "Session file (.h5)")->required();
  cmd->add_option("--output,-o", flags->out_dir,
                  "Directory for the pictures (made, with its parents, when missing)")
      ->capture_default_str();
  cmd->add_option("--python", flags->python, "Python with matplotlib and h5py")
      ->capture_default_str();
  cmd->callback([flags] { run_report(*flags); });
}

}  // namespace hapvox::cli
