#include "engine/io/child_read.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <new>
#include <vector>

#include "engine/errors.h"

// Defined only when a sanitizer runtime is linked (the fuzz and sanitizer builds).
extern "C" void __sanitizer_set_death_callback(void (*callback)()) __attribute__((weak));

namespace hapvox::engine::io {
namespace {

enum class Answer : std::uint8_t { kVolume = 0, kInputError = 1, kOtherError = 2 };

// The child's side: everything goes into one buffer, written at the end.
class Writer {
 public:
  template <typename T>
  void put(const T& value) {
    const auto* p = reinterpret_cast<const char*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void put_string(const std::string& s) {
    put(static_cast<std::uint64_t>(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  // The samples are sent from where they are, after the rest: no second copy of the volume.
  void put_floats(const std::vector<float>& v) {
    put(static_cast<std::uint64_t>(v.size()));
    floats_ = &v;
  }
  void send(int fd) const {
    send_bytes(fd, bytes_.data(), bytes_.size());
    if (floats_ != nullptr) {
      send_bytes(fd, reinterpret_cast<const char*>(floats_->data()),
                 floats_->size() * sizeof(float));
    }
  }

 private:
  static void send_bytes(int fd, const char* data, std::size_t size) {
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::write(fd, data + done, size - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return;  // the parent reports a short answer
      done += static_cast<std::size_t>(n);
    }
  }

  std::vector<char> bytes_;
  const std::vector<float>* floats_ = nullptr;
};

// Caps the child's address space at what it has mapped now plus `budget_bytes`: a corrupt
// header must not make the library allocate gigabytes (GDCM took 2.4 GB for a mutated 39 kB
// file). Relative to what is mapped, so it works beside a sanitizer's shadow memory too.
void limit_memory(std::uint64_t budget_bytes) {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t pages = 0;
  if (!(statm >> pages)) return;
  const std::uint64_t mapped = pages * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
  const rlimit limit{mapped + budget_bytes, mapped + budget_bytes};
  ::setrlimit(RLIMIT_AS, &limit);
}

// The parent's side: reads exactly what the child wrote; false when the pipe ends first.
class Reader {
 public:
  explicit Reader(int fd) : fd_(fd) {}
  bool get_bytes(void* out, std::size_t size) {
    auto* p = static_cast<char*>(out);
    while (size > 0) {
      const ssize_t n = ::read(fd_, p, size);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      p += n;
      size -= static_cast<std::size_t>(n);
    }
    return true;
  }
  template <typename T>
  bool get(T* value) {
    return get_bytes(value, sizeof(T));
  }
  bool get_string(std::string* s) {
    std::uint64_t size = 0;
    if (!get(&size) || size > (std::uint64_t{1} << 20)) return false;
    s->resize(size);
    return get_bytes(s->data(), size);
  }
  bool get_floats(std::vector<float>* v) {
    std::uint64_t size = 0;
    if (!get(&size) || size > static_cast<std::uint64_t>(kMaxSamples)) return false;
    v->resize(size);
    return get_bytes(v->data(), size * sizeof(float));
  }

 private:
  int fd_;
};

void answer(int fd, RawVolume (*read)(const std::string&), const std::string& path,
            const std::string& library, std::uint64_t budget_bytes) {
  Writer out;
  RawVolume raw;
  try {
    raw = read(path);
    out.put(Answer::kVolume);
    out.put(raw.dims);
    out.put(raw.spacing_mm);
    out.put(raw.origin_mm);
    out.put(raw.direction);
    out.put(static_cast<std::uint8_t>(raw.holds_density));
    out.put_string(raw.sample_type);
    out.put(raw.min_intensity);
    out.put(raw.max_intensity);
    out.put_floats(raw.intensity);
  } catch (const InputError& e) {
    out = Writer();
    out.put(Answer::kInputError);
    out.put_string(e.source());
    out.put_string(e.problem());
  } catch (const std::bad_alloc&) {
    out = Writer();
    out.put(Answer::kInputError);
    out.put_string(path);
    out.put_string(library + " needed more than " + std::to_string(budget_bytes >> 20) +
                   " MB reading it: a corrupt file");
  } catch (const std::exception& e) {
    out = Writer();
    out.put(Answer::kOtherError);
    out.put_string(e.what());
  }
  out.send(fd);
}

std::string crash_problem(const std::string& library, int status) {
  std::string how = "it exited with status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    const char* name = sigdescr_np(signal);
    how = "signal " + std::to_string(signal) + (name != nullptr ? std::string(", ") + name : "");
  }
  return library + " crashed reading it (" + how + "): a corrupt or truncated file";
}

}  // namespace

RawVolume read_in_child_process(const std::string& path, RawVolume (*read)(const std::string&),
                                const std::string& library, std::uint64_t budget_bytes) {
  int fds[2];
  // Close-on-exec: a program another thread starts must not hold the pipe open.
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    throw InputError(path, std::string("cannot start a reader process: ") + std::strerror(errno));
  }
  const pid_t child = ::fork();
  if (child < 0) {
    const int error = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw InputError(path, std::string("cannot start a reader process: ") + std::strerror(error));
  }
  if (child == 0) {
    ::close(fds[0]);
    // The library's own last words (an assertion's text) would make the error two lines.
    const int null_fd = ::open("/dev/null", O_WRONLY);
    if (null_fd >= 0) ::dup2(null_fd, STDERR_FILENO);
    // A crash ends the child at once: no crash handler of the parent's (a fuzzer's, which
    // would report the parent's input as crashing) runs in it.
    for (const int signal : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) {
      std::signal(signal, SIG_DFL);
    }
    // Likewise a sanitizer's death callback (libFuzzer's, which writes a crash file), run
    // when the sanitizer's allocator meets the address-space cap.
    if (__sanitizer_set_death_callback != nullptr) __sanitizer_set_death_callback(nullptr);
    limit_memory(budget_bytes);
    answer(fds[1], read, path, library, budget_bytes);
    ::close(fds[1]);
    // No destructors, atexit handlers or buffered output of the parent's: they are its.
    ::_exit(0);
  }
  ::close(fds[1]);
  Reader in(fds[0]);
  Answer kind{};
  bool complete = in.get(&kind);
  RawVolume raw;
  std::string source, problem;
  if (complete) {
    switch (kind) {
      case Answer::kVolume: {
        std::uint8_t holds_density = 0;
        complete = in.get(&raw.dims) && in.get(&raw.spacing_mm) && in.get(&raw.origin_mm) &&
                   in.get(&raw.direction) && in.get(&holds_density) &&
                   in.get_string(&raw.sample_type) && in.get(&raw.min_intensity) &&
                   in.get(&raw.max_intensity) && in.get_floats(&raw.intensity);
        raw.holds_density = holds_density != 0;
        break;
      }
      case Answer::kInputError:
        complete = in.get_string(&source) && in.get_string(&problem);
        break;
      case Answer::kOtherError:  // a library's own exception: its text, made one line
        complete = in.get_string(&problem);
        problem = library + " failed reading it: " + printable(problem, 200);
        source = path;
        break;
      default:
        complete = false;
    }
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (!complete || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw InputError(path, crash_problem(library, status));
  }
  if (kind != Answer::kVolume) throw InputError(source, problem);
  return raw;
}

}  // namespace hapvox::engine::io
