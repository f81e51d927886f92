#include "io/isolated.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <stdexcept>

namespace maps::io {
namespace {

// What the child writes first: whether `work` returned or threw. A child that writes neither died: the verdict does
// not rest on its exit status, which a sanitizer's report (exit 1) or a host that reaps children itself (SIGCHLD
// ignored) would blur.
constexpr char kReturned = 'R';
constexpr char kThrew = 'T';
constexpr std::size_t kMaxMessage = 64 * 1024;

void write_all(int fd, const std::string& text) {
  for (std::size_t sent = 0; sent < text.size();) {
    const ssize_t n = ::write(fd, text.data() + sent, text.size() - sent);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    sent += static_cast<std::size_t>(n);
  }
}

}  // namespace

IsolatedOutcome run_isolated(const std::function<void()>& work, double seconds) {
  int fds[2];
  // Close-on-exec: a program another thread starts meanwhile must not hold the write end open (the parent would
  // wait for an end of file that never comes).
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw std::runtime_error(std::string("run_isolated: pipe: ") + std::strerror(errno));
  const pid_t child = ::fork();
  if (child < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(std::string("run_isolated: fork: ") + std::strerror(err));
  }
  if (child == 0) {
    ::close(fds[0]);
    std::string report(1, kReturned);
    try {
      work();
    } catch (const std::exception& e) {
      report = std::string(1, kThrew) + std::string(e.what()).substr(0, kMaxMessage);
    } catch (...) {
      report = std::string(1, kThrew) + "an exception that is not a std::exception";
    }
    write_all(fds[1], report);
    // No exit handlers: they belong to the parent (its test framework, the libraries' atexit cleanups).
    ::_exit(0);
  }
  ::close(fds[1]);
  IsolatedOutcome outcome;
  std::string report;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  char buffer[4096];
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      outcome.timed_out = true;
      ::kill(child, SIGKILL);
      break;
    }
    pollfd reader{fds[0], POLLIN, 0};
    const int ready = ::poll(&reader, 1, static_cast<int>(std::min<long long>(left, 1000)));
    if (ready <= 0) continue;  // a timeout of this poll, or EINTR
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the child closed its end: it is exiting
    if (report.size() < kMaxMessage + 1) report.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  pid_t reaped;
  while ((reaped = ::waitpid(child, &status, 0)) < 0 && errno == EINTR) {
  }
  // A host that ignores SIGCHLD has the child reaped already (ECHILD): its status is unknown, the report still tells.
  if (reaped == child && WIFSIGNALED(status) && !outcome.timed_out) outcome.signal = WTERMSIG(status);
  if (reaped == child && WIFEXITED(status) && WEXITSTATUS(status) != 0) outcome.exit_status = WEXITSTATUS(status);
  outcome.finished = !outcome.timed_out && !report.empty() && (report[0] == kReturned || report[0] == kThrew) &&
                     outcome.signal == 0 && outcome.exit_status == 0;
  if (outcome.finished && report[0] == kThrew) outcome.error = report.substr(1);
  return outcome;
}

}  // namespace maps::io
