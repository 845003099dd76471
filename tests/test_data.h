#pragma once
// Paths to data shipped in the repository (data/, traces/) and scratch space for tests.

#include <string>

namespace hapvox::testing {

/// HAPVOX_SOURCE_DIR + "/" + relative.
std::string source_path(const std::string& relative);
/// The hapvox executable built alongside the tests.
std::string hapvox_binary();
/// A fresh, empty directory unique to the running test.
std::string scratch_dir();

}  // namespace hapvox::testing
