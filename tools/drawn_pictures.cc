#include "tools/drawn_pictures.h"

#include <stdlib.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "engine/text_file.h"

namespace hapvox::cli {

int draw_into(const std::string& out_dir, const std::vector<std::string>& names,
              const std::string& prefix, const std::function<int(const std::string&)>& draw) {
  for (const std::string& name : names) {
    engine::io::check_output_target((std::filesystem::path(out_dir) / name).string());
  }
  std::string folder = (std::filesystem::path(out_dir) / ".hapvox-drawing.XXXXXX").string();
  if (::mkdtemp(folder.data()) == nullptr) {
    throw InputError(out_dir,
                     "cannot make a folder to draw in (" + std::string(std::strerror(errno)) + ")");
  }
  struct RemoveFolder {
    std::string path;
    ~RemoveFolder() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } remove_folder{folder};
  const int status = draw(folder);
  if (status != 0) return status;
  for (const std::string& name : names) {
    const std::filesystem::path drawn = std::filesystem::path(folder) / name;
    if (!std::filesystem::is_regular_file(std::filesystem::symlink_status(drawn))) continue;
    const std::string path = (std::filesystem::path(out_dir) / name).string();
    engine::io::write_text_atomically(path, engine::read_text_file(drawn.string()));
    std::printf("%s%s\n", prefix.c_str(), path.c_str());
  }
  return 0;
}

}  // namespace hapvox::cli
