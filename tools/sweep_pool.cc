#include "tools/sweep_pool.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <thread>

#include "engine/errors.h"

namespace hapvox::cli {
namespace {

// Starts one job; returns its pid. In the child only async-signal-safe calls after fork.
pid_t start(const PoolJob& job, const std::string& program) {
  std::vector<std::string> argv_text;
  argv_text.push_back(program);
  argv_text.insert(argv_text.end(), job.args.begin(), job.args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int log = ::open(job.log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log < 0) {
    throw InputError(job.log_path, std::string("cannot be written: ") + std::strerror(errno));
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log);
    throw InputError("sweep", std::string("cannot start a replay: ") + std::strerror(errno));
  }
  if (pid == 0) {
    // The child: the row's folder, its log, the default signal actions, then this program.
    if (::chdir(job.working_dir.c_str()) != 0) ::_exit(126);
    ::dup2(log, STDOUT_FILENO);
    ::dup2(log, STDERR_FILENO);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::execv(job.executable.c_str(), argv.data());
    ::_exit(127);
  }
  ::close(log);
  return pid;
}

JobStatus status_of(int wait_status) {
  if (WIFEXITED(wait_status)) return WEXITSTATUS(wait_status);
  if (WIFSIGNALED(wait_status)) return 128 + WTERMSIG(wait_status);
  return 255;
}

}  // namespace

void run_pool(const std::vector<PoolJob>& jobs, int parallel, const std::string& program,
              const std::atomic<bool>& stop, const std::function<void(std::size_t)>& on_start,
              const std::function<void(std::size_t, JobStatus)>& on_end) {
  std::map<pid_t, std::size_t> running;
  std::size_t next = 0;
  bool signalled = false;
  while (next < jobs.size() || !running.empty()) {
    const bool stopping = stop.load(std::memory_order_relaxed);
    while (!stopping && next < jobs.size() && static_cast<int>(running.size()) < parallel) {
      running[start(jobs[next], program)] = next;
      on_start(next);
      ++next;
    }
    if (stopping) {
      next = jobs.size();
      if (!signalled) {
        for (const auto& [pid, job] : running) ::kill(pid, SIGTERM);
        signalled = true;
      }
    }
    if (running.empty()) break;
    // Poll, so that a stop request is seen within 50 ms (a signal interrupts no wait here).
    int wait_status = 0;
    const pid_t pid = ::waitpid(-1, &wait_status, WNOHANG);
    if (pid > 0) {
      const auto it = running.find(pid);
      if (it == running.end()) continue;  // not one of ours
      const std::size_t job = it->second;
      running.erase(it);
      on_end(job, status_of(wait_status));
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
}

}  // namespace hapvox::cli
