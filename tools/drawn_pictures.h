#pragma once
// Pictures a Python script draws (matplotlib, which opens its files by name), brought into
// an output directory through the output module (engine/io/output_file.h) like every file
// hapvox writes: `hapvox report`'s and `hapvox validate hertz`'s PNGs.

#include <functional>
#include <string>
#include <vector>

namespace hapvox::cli {

/// Checks each OUT_DIR/NAME as an output (no link, no special file, no NAME.partial), runs
/// `draw(folder)` with a private folder (mkdtemp, 0700: no one else can plant a link there)
/// inside `out_dir`, and writes each picture `draw` left there to OUT_DIR/NAME through the
/// output module (NAME.partial, exclusive, renamed), printing its path after `prefix`, in
/// `names`' order. The folder is removed either way. Returns draw's status (non-zero: no
/// picture is moved). Throws InputError.
int draw_into(const std::string& out_dir, const std::vector<std::string>& names,
              const std::string& prefix, const std::function<int(const std::string&)>& draw);

}  // namespace hapvox::cli
