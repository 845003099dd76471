#include "engine/io/output_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "engine/errors.h"

namespace hapvox::engine::io {

namespace {

namespace fs = std::filesystem;

std::string errno_text(int error) { return std::strerror(error); }

// What is at `path`, not following a link: 0 when nothing is there.
mode_t file_type(const std::string& path, int* error = nullptr) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (error != nullptr) *error = errno;
    return 0;
  }
  return st.st_mode & S_IFMT;
}

// Throws unless PATH names nothing or a regular file (never a link, a directory, a device).
void check_replaceable(const std::string& path) {
  int error = 0;
  const mode_t type = file_type(path, &error);
  if (type == 0 && error != ENOENT && error != 0) {
    throw InputError(path, "cannot be written: " + errno_text(error));
  }
  if (type == S_IFLNK) {
    throw InputError(path,
                     "is a symbolic link: outputs are never written through links (remove it, or "
                     "name the file it points to)");
  }
  if (type == S_IFDIR) throw InputError(path, "is a directory, expected a file name");
  if (type != 0 && type != S_IFREG) {
    throw InputError(path,
                     "is not a regular file (a device, FIFO or socket): outputs are written to "
                     "regular files only");
  }
}

// Throws if something is at the partial path: a link, a run writing it, or a killed run's.
void check_no_partial(const std::string& path, const std::string& partial) {
  const mode_t type = file_type(partial);
  if (type == 0) return;
  if (type == S_IFLNK) {
    throw InputError(path,
                     partial + " is a symbolic link: refusing to write through it (remove it)");
  }
  if (type == S_IFREG) {
    const int fd = ::open(partial.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    const bool locked = fd >= 0 && ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    if (fd >= 0) ::close(fd);
    if (locked) throw InputError(path, "another run is writing it (" + partial + " is locked)");
  }
  throw InputError(
      path, partial + " is left from a run that did not finish: recover it (hapvox recover " +
                partial + ", for a session) or remove it");
}

}  // namespace

void check_name_lengths(const std::string& path, const std::string& suffix) {
  const fs::path p(path);
  const fs::path parent = p.parent_path();
  const long name_max = ::pathconf(parent.empty() ? "." : parent.c_str(), _PC_NAME_MAX);
  const std::size_t limit = name_max > 0 ? static_cast<std::size_t>(name_max) : 255;
  const auto refuse = [&](const std::string& problem) {
    throw InputError(printable(path, 120), problem + ", longer than the file system allows (" +
                                               std::to_string(limit) + ")");
  };
  for (const fs::path& part : parent) {
    if (part.native().size() > limit) {
      refuse("a folder name of " + std::to_string(part.native().size()) + " bytes");
    }
  }
  const std::size_t bytes = p.filename().native().size();
  if (bytes + suffix.size() > limit) {
    refuse("a file name of " + std::to_string(bytes) + " bytes (" +
           std::to_string(bytes + suffix.size()) + " as NAME" + suffix + ", while it is written)");
  }
}

void check_output_target(const std::string& path, const std::string& suffix) {
  if (path.empty()) throw InputError("output", "an output path is required");
  check_name_lengths(path, suffix);
  const fs::path p(path);
  const fs::path parent = p.parent_path();
  std::error_code ec;
  if (!parent.empty() && !fs::is_directory(parent, ec)) {
    throw InputError(path, "output directory " + parent.string() + " does not exist");
  }
  check_replaceable(path);
  check_no_partial(path, path + suffix);
}

OutputFile::OutputFile(std::string path, std::string suffix)
    : path_(std::move(path)), partial_path_(path_ + suffix) {
  check_output_target(path_, suffix);
  fd_ = ::open(partial_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    const int error = errno;
    if (error == EEXIST) check_no_partial(path_, partial_path_);  // lost a race: say to whom
    throw InputError(path_, "cannot create " + partial_path_ + ": " + errno_text(error));
  }
  struct stat st {};
  ::fstat(fd_, &st);
  device_ = st.st_dev;
  inode_ = st.st_ino;
  // Held until the file is in place: a second run sees the partial locked, not left over.
  ::flock(fd_, LOCK_EX | LOCK_NB);
}

OutputFile::~OutputFile() {
  if (fd_ >= 0) ::close(fd_);
}

void OutputFile::verify() const {
  struct stat st {};
  if (::lstat(partial_path_.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_dev != device_ ||
      st.st_ino != inode_) {
    throw InputError(path_, partial_path_ + " was replaced while it was written");
  }
}

void OutputFile::write(const void* data, std::size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd_, bytes, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw InputError(path_, "error while writing " + partial_path_ + ": " + errno_text(errno));
    bytes += n;
    size -= static_cast<std::size_t>(n);
  }
}

void OutputFile::commit() {
  verify();
  check_replaceable(path_);
  if (::rename(partial_path_.c_str(), path_.c_str()) != 0) {
    throw InputError(path_, "cannot move " + partial_path_ + " into place: " + errno_text(errno));
  }
  ::close(fd_);
  fd_ = -1;
}

void OutputFile::discard() noexcept {
  if (fd_ < 0) return;
  struct stat st {};
  if (::lstat(partial_path_.c_str(), &st) == 0 && st.st_dev == device_ && st.st_ino == inode_) {
    ::unlink(partial_path_.c_str());
  }
  ::close(fd_);
  fd_ = -1;
}

void write_file_atomically(const std::string& path, std::initializer_list<Bytes> pieces) {
  OutputFile out(path);
  try {
    for (const Bytes& piece : pieces) out.write(piece.data, piece.size);
    out.commit();
  } catch (...) {
    out.discard();
    throw;
  }
}

void write_text_atomically(const std::string& path, const std::string& text) {
  write_file_atomically(path, {{text.data(), text.size()}});
}

}  // namespace hapvox::engine::io
