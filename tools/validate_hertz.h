#pragma once
// `hapvox validate hertz` (tools/validate_hertz.cc): the contact law against Hertz on a flat
// face from a quarter voxel deep, and on a sphere's pole and diagonal, checked and drawn.

#include <CLI/CLI.hpp>

namespace hapvox::cli {

/// Adds `hertz` to the `validate` command.
void add_validate_hertz(CLI::App& validate);

}  // namespace hapvox::cli
