// hapvox: touch, press and sculpt 3D images with a haptic tool.
//
// Exit codes: 0 success, 1 internal error, 2 bad input (files, traces, flags, configs),
// 3 check-timing: the force loop broke its timing budget.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <iostream>

#include "engine/errors.h"
#include "engine/version.h"
#include "haptics/session.h"
#include "render/gl_context.h"
#include "tools/cli.h"
#include "tools/command_exit.h"

namespace hapvox::cli {
void add_render_command(CLI::App& app);          // tools/cmd_render.cc
void add_bench_render_command(CLI::App& bench);  // tools/cmd_bench_render.cc
void add_mesh_command(CLI::App& app);            // tools/cmd_mesh.cc
void add_convert_command(CLI::App& app);         // tools/cmd_convert.cc
void add_recover_command(CLI::App& app);         // tools/cmd_recover.cc
void add_device_sim_command(CLI::App& app);      // tools/cmd_device_sim.cc
void add_sculpt_command(CLI::App& app);          // tools/cmd_sculpt.cc
void add_sweep_command(CLI::App& app);           // tools/cmd_sweep.cc
void add_input_limit_flags(CLI::App& app);       // tools/input_limits.cc
}  // namespace hapvox::cli

namespace {

// Every diagnostic is one line of printable text, whatever a message echoes (file contents,
// a binary file's name, a flag's value): control and non-ASCII bytes as \xNN, cut short.
void print_diagnostic(const char* kind, const std::string& what, const char* suffix = "") {
  std::fprintf(stderr, "hapvox: %s: %s%s\n", kind, hapvox::printable(what, 400).c_str(), suffix);
}

bool is_command_of(const CLI::App& app, const std::string& name) {
  const auto commands = app.get_subcommands([](const CLI::App*) { return true; });
  return std::any_of(commands.begin(), commands.end(),
                     [&](const CLI::App* c) { return c->check_name(name); });
}

// CLI11 answers `hapvox no-such-command --help` with the top-level help (exit 0) and
// `hapvox no-such-command` with "arguments were not expected": both are an unknown command.
// The first word that is not a flag names the command (the top level has no options taking
// values); a command with commands of its own (trace, bench) and no positional arguments
// takes the next word, when it is not a flag, as one of them.
void check_command_names(const CLI::App& app, int argc, char** argv) {
  int i = 1;
  while (i < argc && argv[i][0] == '-' && std::string(argv[i]) != "--") ++i;
  if (i >= argc || std::string(argv[i]) == "--") return;
  const std::string name = argv[i];
  if (!is_command_of(app, name)) {
    throw hapvox::InputError(name, "unknown command (see hapvox --help)");
  }
  const CLI::App* command = app.get_subcommand(name);
  const bool has_positionals =
      !command->get_options([](const CLI::Option* o) { return o->get_positional(); }).empty();
  if (i + 1 >= argc || argv[i + 1][0] == '-' || has_positionals ||
      command->get_subcommands([](const CLI::App*) { return true; }).empty()) {
    return;
  }
  const std::string sub = argv[i + 1];
  if (!is_command_of(*command, sub)) {
    throw hapvox::InputError(sub, "unknown command (see hapvox " + name + " --help)");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hapvox: touch, press and sculpt 3D images with a haptic tool at 1 kHz", "hapvox"};
  app.require_subcommand(1);
  app.set_version_flag("--version", [] {
    std::string text;
    for (const auto& [name, version] : hapvox::haptics::library_versions()) {
      text += (text.empty() ? "" : "\n") + name + " " + version;
    }
    return text;
  });
  hapvox::cli::set_command_line(argc, argv);
  hapvox::cli::add_replay_command(app);
  hapvox::cli::add_check_timing_command(app);
  hapvox::cli::add_report_command(app);
  hapvox::cli::add_info_command(app);
  hapvox::cli::add_bench_command(app);
  hapvox::cli::add_bench_render_command(*app.get_subcommand("bench"));
  hapvox::cli::add_trace_command(app);
  hapvox::cli::add_render_command(app);
  hapvox::cli::add_validate_command(app);
  hapvox::cli::add_mesh_command(app);
  hapvox::cli::add_convert_command(app);
  hapvox::cli::add_recover_command(app);
  hapvox::cli::add_device_sim_command(app);
  hapvox::cli::add_sculpt_command(app);
  hapvox::cli::add_sweep_command(app);
  hapvox::cli::add_input_limit_flags(app);
  try {
    hapvox::cli::check_numeric_options(app);  // after every option is added
    check_command_names(app, argc, argv);
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    print_diagnostic("error", e.what(), " (see hapvox --help)");
    return 2;
  } catch (const hapvox::InputError& e) {
    // Its parts, not what(): a C string, which stops at a NUL a file's text may hold.
    print_diagnostic("error", e.source() + ": " + e.problem());
    return 2;
  } catch (const hapvox::render::RenderError& e) {
    // No EGL, no surfaceless platform, a driver refusing the context: the machine's
    // set-up, not an internal error.
    print_diagnostic("error", e.what());
    return 2;
  } catch (const hapvox::cli::TimingBudgetBroken& e) {
    print_diagnostic("check-timing", e.what());
    return 3;
  } catch (const hapvox::cli::CommandExit& e) {
    return e.status;
  } catch (const hapvox::cli::ValidationFailed& e) {
    std::fprintf(stderr, "hapvox: validate: %s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    print_diagnostic("internal error", e.what());
    return 1;
  }
  return 0;
}
