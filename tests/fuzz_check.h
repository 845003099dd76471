#pragma once
// The fuzz targets' contract for a refused input: an InputError whose message is one line
// that starts with the source read (the file, folder or spec) and says what is wrong.

#include <cstdlib>
#include <string>

#include "engine/errors.h"

namespace hapvox::testing {

/// Aborts (a crash libFuzzer reports) unless `e` keeps the contract for `source`.
inline void abort_unless_one_line_error(const InputError& e, const std::string& source) {
  const std::string what = e.what();
  if (what.rfind(source, 0) != 0 || what.find('\n') != std::string::npos || e.problem().empty()) {
    std::abort();
  }
}

}  // namespace hapvox::testing
