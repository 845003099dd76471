#pragma once
// A small input file (materials, incision) read whole, with the errors every reader gives.

#include <string>

namespace hapvox::engine {

/// The bytes of the file at `path`. Throws InputError(path, "is a directory" / "cannot open
/// file" / "cannot read file"), and InputError(path, "holds N MB, over the limit ...") past
/// --max-input-mb (engine/input_limits.h), before reading it.
std::string read_text_file(const std::string& path);

}  // namespace hapvox::engine
