// hapvox report SESSION.h5 -o DIR: pictures of a session (force over time, lateness
// histogram, queue depth and relaxation work), drawn by matplotlib. hapvox report SWEEP_DIR
// -o DIR: pictures across a sweep (peak force against tool size and stiffness), from its
// summary.h5.
//
// Plotting is left to matplotlib (Debian's python3-matplotlib with python3-h5py) rather
// than hand-written: the script is compiled into the binary (tools/report.py) and run
// with the system python3, so the command works from any directory.

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "engine/errors.h"
#include "haptics/session.h"
#include "haptics/session_recover.h"
#include "tools/cli.h"
#include "tools/drawn_pictures.h"
#include "tools/report_script.h"
#include "tools/sweep_report_script.h"

namespace hapvox::cli {
namespace {

struct ReportFlags {
  std::string session;
  std::string out_dir = ".";
  std::string python = "/usr/bin/python3";
};

void check_python(const std::string& python) {
  const std::string probe =
      shell_quoted(python) + " -c 'import matplotlib, h5py, numpy' 2>/dev/null";
  if (std::system(probe.c_str()) != 0) {
    throw InputError("--python", python +
                                     " cannot import matplotlib, h5py and numpy (install "
                                     "python3-matplotlib python3-h5py; scripts/setup.sh does)");
  }
}

// The pictures' directory (and its parents) is made when missing, as `-o plots/` on a fresh
// clone expects; only once everything else has been checked.
void make_output_dir(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (!std::filesystem::is_directory(dir)) {
    throw InputError(dir, "cannot create the output directory" +
                              (error ? " (" + error.message() + ")" : std::string()));
  }
}

// A sweep's directory: its summary.h5 drawn.
void run_sweep_report(const ReportFlags& f) {
  const std::string summary = (std::filesystem::path(f.session) / "summary.h5").string();
  if (!haptics::is_hdf5_file(summary)) {
    throw InputError(f.session,
                     "is a directory without a sweep's summary.h5 (hapvox sweep --collect DIR "
                     "writes one)");
  }
  check_outputs_spare_inputs({{f.out_dir, "--output", "sweep_peak_force\\.png"}},
                             {{summary, "sweep summary"}});
  check_python(f.python);
  make_output_dir(f.out_dir);
  const int status =
      draw_into(f.out_dir, {"sweep_peak_force.png"}, "wrote ", [&](const std::string& folder) {
        return run_python_script(f.python, kSweepReportScript, "sweep_report", {summary, folder});
      });
  if (status != 0) {
    throw InputError(summary,
                     "plotting failed (python exit status " + std::to_string(status) + ")");
  }
}

void run_report(const ReportFlags& f) {
  if (std::filesystem::is_directory(f.session)) return run_sweep_report(f);
  if (!haptics::is_hdf5_file(f.session)) {
    throw InputError(f.session, std::filesystem::exists(f.session) ? "not an HDF5 session file"
                                                                   : "no such file");
  }
  check_outputs_spare_inputs({{f.out_dir, "--output", "(force|lateness|relax)\\.png"}},
                             {{f.session, "session"}});
  const haptics::SessionInfo info = haptics::read_session_info(f.session);
  if (info.rows == 0) throw InputError(f.session, "the session has no rows");
  check_python(f.python);
  make_output_dir(f.out_dir);
  // A session a killed run left (h5py refuses it): drawn from a recovered copy.
  std::string drawn = f.session;
  if (!info.complete) {
    drawn = (std::filesystem::temp_directory_path() /
             ("hapvox_report_" + std::to_string(getpid()) + ".h5"))
                .string();
    const haptics::RecoveredSession recovered = haptics::recover_session(f.session, drawn);
    std::printf(
        "%s did not finish: drawn from the %zu rows it holds (hapvox recover %s makes "
        "it a complete session)\n",
        f.session.c_str(), recovered.rows, f.session.c_str());
  }
  const int status = draw_into(
      f.out_dir, {"force.png", "lateness.png", "relax.png"}, "", [&](const std::string& folder) {
        return run_python_script(f.python, kReportScript, "report", {drawn, folder});
      });
  if (drawn != f.session) std::filesystem::remove(drawn);
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
      "directory; or a sweep's directory: sweep_peak_force.png (peak force against tool size "
      "and stiffness)");
  cmd->add_option("session", flags->session, "Session file (.h5), or a sweep's directory")
      ->required();
  cmd->add_option("--output,-o", flags->out_dir,
                  "Directory for the pictures (made, with its parents, when missing)")
      ->capture_default_str();
  cmd->add_option("--python", flags->python, "Python with matplotlib and h5py")
      ->capture_default_str();
  cmd->callback([flags] { run_report(*flags); });
}

}  // namespace hapvox::cli
