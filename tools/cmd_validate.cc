// hapvox validate: the physics against closed forms, one subcommand per check
// (tools/validate_hertz.cc, tools/validate_contact.cc). Exit 3 when one fails.

#include "tools/cli.h"
#include "tools/validate_contact.h"
#include "tools/validate_hertz.h"

namespace hapvox::cli {

void add_validate_command(CLI::App& app) {
  CLI::App* validate = app.add_subcommand(
      "validate", "Check the physics against closed-form solutions (exit 3 when one fails)");
  validate->require_subcommand(1);
  add_validate_hertz(*validate);
  add_validate_contact(*validate);
}

}  // namespace hapvox::cli
