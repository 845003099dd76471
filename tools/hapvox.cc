// hapvox: touch, press and sculpt 3D images with a haptic tool.
//
// Exit codes: 0 success, 1 internal error, 2 bad input (files, traces, flags, configs),
// 3 check-timing: the force loop broke its timing budget.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "engine/errors.h"
#include "engine/version.h"
#include "haptics/session.h"
#include "render/gl_context.h"
#include "tools/cli.h"

namespace hapvox::cli {
void add_render_command(CLI::App& app);          // tools/cmd_render.cc
void add_bench_render_command(CLI::App& bench);  // tools/cmd_bench_render.cc
}  // namespace hapvox::cli

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
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "hapvox: error: %s (see hapvox --help)\n", e.what());
    return 2;
  } catch (const hapvox::InputError& e) {
    std::fprintf(stderr, "hapvox: error: %s\n", e.what());
    return 2;
  } catch (const hapvox::render::RenderError& e) {
    // No EGL, no surfaceless platform, a driver refusing the context: the machine's
    // set-up, not an internal error.
    std::fprintf(stderr, "hapvox: error: %s\n", e.what());
    return 2;
  } catch (const hapvox::cli::TimingBudgetBroken& e) {
    std::fprintf(stderr, "hapvox: check-timing: %s\n", e.what());
    return 3;
  } catch (const hapvox::cli::ValidationFailed& e) {
    std::fprintf(stderr, "hapvox: validate: %s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hapvox: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
