// The flags that raise (or lower) the input budgets of engine/input_limits.h, registered on
// every command at once: each command that reads files reads them through the readers that
// check the budgets, so each takes the flags.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "engine/input_limits.h"

namespace hapvox::cli {
namespace {

void add_limit(CLI::App& app, const std::string& flag, std::uint64_t* limit,
               const std::string& help) {
  app.add_option_function<std::uint64_t>(
         flag, [limit](std::uint64_t value) { *limit = value; },
         help + " (default " + std::to_string(*limit) + "; docs/formats.md, \"Limits\")")
      ->check(CLI::PositiveNumber)
      ->group("Input limits");
}

void add_to_command(CLI::App& command) {
  engine::InputLimits& limits = engine::input_limits();
  add_limit(command, "--max-input-mb", &limits.max_input_mb,
            "Largest volume, decoded (4 bytes a sample), and largest text input, in MB");
  add_limit(command, "--max-trace-rows", &limits.max_trace_rows,
            "Most samples a trace may hold, and most ticks it may make at the loop rate");
  if (command.get_name() == "sweep") {
    add_limit(command, "--max-sweep-rows", &limits.max_sweep_rows,
              "Most replays a sweep manifest may describe");
  }
  for (CLI::App* sub : command.get_subcommands([](const CLI::App*) { return true; })) {
    add_to_command(*sub);
  }
}

}  // namespace

/// Registers --max-input-mb and --max-trace-rows on every command below `app` (and
/// --max-sweep-rows on `sweep`): call it once all commands are added.
void add_input_limit_flags(CLI::App& app) {
  for (CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) {
    add_to_command(*command);
  }
}

}  // namespace hapvox::cli
