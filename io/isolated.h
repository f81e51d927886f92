#pragma once
// Work on untrusted input that a third-party library may crash on or loop in (libhdf5 1.10 overflows a buffer in
// H5HG_read on a damaged global heap): run it first in a forked child, whose death or hang is reported instead of
// taking the program with it.

#include <functional>
#include <string>

namespace maps::io {

struct IsolatedOutcome {
  bool finished = false;  // the child returned from `work` or threw (then `error` holds what())
  std::string error;
  int signal = 0;          // the signal that killed the child (0: none)
  int exit_status = 0;     // it exited otherwise than returning or throwing (a sanitizer report): its status
  bool timed_out = false;  // killed after `seconds`
};

// Runs `work` in a child process (fork) and waits up to `seconds`. The child's memory is a copy: nothing `work`
// does reaches the caller but the outcome. Throws std::runtime_error when no child can be made.
IsolatedOutcome run_isolated(const std::function<void()>& work, double seconds);

}  // namespace maps::io
