#pragma once
// `hapvox validate contact` (tools/validate_contact.cc): the Hertz law's energy on sticking
// loops, its Coulomb friction and an oblique press, checked and drawn.

#include <CLI/CLI.hpp>

namespace hapvox::cli {

/// Adds `contact` to the `validate` command.
void add_validate_contact(CLI::App& validate);

}  // namespace hapvox::cli
