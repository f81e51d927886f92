#include "io/isolated.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <stdexcept>

namespace maps::io {
namespace {

// The child's exit status when `work` threw. Not 1: a sanitizer that finds an error in the child exits with 1, and
// that is a crash, not a refusal.
constexpr int kThrew = 77;

}  // namespace

IsolatedOutcome run_isolated(const std::function<void()>& work, double seconds) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error(std::string("run_isolated: pipe: ") + std::strerror(errno));
  const pid_t child = ::fork();
  if (child < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(std::string("run_isolated: fork: ") + std::strerror(err));
  }
  if (child == 0) {
    ::close(fds[0]);
    int status = 0;
    std::string message;
    try {
      work();
    } catch (const std::exception& e) {
      message = e.what();
      status = kThrew;
    } catch (...) {
      message = "an exception that is not a std::exception";
      status = kThrew;
    }
    for (std::size_t sent = 0; sent < message.size();) {
      const ssize_t n = ::write(fds[1], message.data() + sent, message.size() - sent);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    // No exit handlers: they belong to the parent (its test framework, the libraries' atexit cleanups).
    ::_exit(status);
  }
  ::close(fds[1]);
  IsolatedOutcome outcome;
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
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the child closed its end: it is exiting
    outcome.error.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status) && !outcome.timed_out) outcome.signal = WTERMSIG(status);
  outcome.finished = WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == kThrew);
  if (WIFEXITED(status) && !outcome.finished) outcome.exit_status = WEXITSTATUS(status);
  return outcome;
}

}  // namespace maps::io
