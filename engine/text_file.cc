#include "engine/text_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "engine/errors.h"
#include "engine/input_limits.h"

namespace hapvox::engine {

std::string read_text_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open file");
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (!ec) check_text_bytes(bytes, path);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path, "cannot read file");
  return text.str();
}

}  // namespace hapvox::engine
