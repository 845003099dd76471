#pragma once
// Every file hapvox writes goes through here (docs/formats.md, Outputs): an output is
// written to PATH.partial, created exclusively and locked for as long as it is written,
// then renamed to PATH. So:
//   - nothing is written through a link or into a special file: a symbolic link at PATH or
//     PATH.partial, a directory, a device node, a FIFO or a socket at PATH is refused;
//   - a second run writing the same PATH is refused before it touches anything (the first
//     run's PATH.partial exists and is locked), and the first run's file stays valid;
//   - a PATH.partial left by a run that was killed is never overwritten: the error says to
//     recover it (`hapvox recover`, for sessions) or remove it;
//   - a file at PATH is always complete, and an existing PATH is replaced only on success.
// A process that writes into PATH.partial through a library that opens files by name (HDF5,
// OpenVDB) opens the file this module created; verify() then checks it is still that file.

#include <initializer_list>
#include <string>

namespace hapvox::engine::io {

/// Throws InputError(PATH, "a file name of N bytes (...), longer than the file system allows
/// (255)") when a folder of `path`, or its file name with `suffix` (it is written first as
/// NAME + suffix), is longer than the file system's NAME_MAX: std::filesystem would throw
/// instead. The path is cut short in the message. Touches nothing.
void check_name_lengths(const std::string& path, const std::string& suffix = ".partial");

/// Throws InputError(path, ...) unless `path` may be written as an output: a name (not
/// empty, check_name_lengths) in an existing directory,
/// naming nothing or a regular file, with no file at PATH + suffix (a run writing it, or a
/// killed run's leftovers). Touches nothing.
void check_output_target(const std::string& path, const std::string& suffix = ".partial");

/// An output being written: PATH + suffix, created with O_CREAT | O_EXCL | O_NOFOLLOW and
/// locked (flock) until commit() or destruction. Not committed, the file stays where it is
/// (a session's rows are kept for a post-mortem) unless discard() removes it.
class OutputFile {
 public:
  /// Claims PATH: checks it (check_output_target) and creates PATH + suffix. Throws
  /// InputError(path, ...) if it cannot.
  explicit OutputFile(std::string path, std::string suffix = ".partial");
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  const std::string& path() const { return path_; }
  const std::string& partial_path() const { return partial_path_; }
  /// The open descriptor of the partial file (write through it, or let a library open the
  /// file by name and call verify()).
  int fd() const { return fd_; }

  /// Throws InputError unless PATH.partial is still the file this object created (nobody
  /// replaced it with a link or another file while a library opened it by name).
  void verify() const;
  /// Writes `size` bytes through fd(). Throws InputError on failure.
  void write(const void* data, std::size_t size);
  /// Moves the partial file to PATH (checking PATH again: still no link, no special file)
  /// and releases the lock. Throws InputError if it cannot.
  void commit();
  /// Removes the partial file, if it is still the one created here, and releases the lock.
  void discard() noexcept;

 private:
  std::string path_;
  std::string partial_path_;
  int fd_ = -1;
  unsigned long long device_ = 0, inode_ = 0;  // the partial file's identity
};

/// A piece of a file to write.
struct Bytes {
  const void* data;
  std::size_t size;
};

/// Writes the pieces to PATH through an OutputFile (PATH.partial, then renamed), so a failed
/// write never leaves a truncated PATH. Throws InputError.
void write_file_atomically(const std::string& path, std::initializer_list<Bytes> pieces);
/// The same for one string.
void write_text_atomically(const std::string& path, const std::string& text);

}  // namespace hapvox::engine::io
