// read_demo_file: read_demo_file_in_process run first in a child process, which libhdf5's crashes on damaged files
// cannot take the caller down with them.

#include <hdf5.h>

#include <string>

#include "envs/demo_file.h"
#include "io/isolated.h"

namespace maps::envs {
namespace {

// Far above what reading a valid demo file takes: a bound only for a child that loops in libhdf5.
constexpr double kIsolatedReadSeconds = 300.0;

}  // namespace

DemoFile read_demo_file(const std::string& path) {
  // libhdf5 1.10 can crash on a damaged file (a buffer overflow in H5HG_read, reading a variable-length string whose
  // global heap entry is damaged: found by the property test, DemoFileProperty) or loop in it. So the file is read
  // first by a child process; its death or hang is a refusal. A file the child read or refused is read here again,
  // which returns it or throws the child's error.
  const io::IsolatedOutcome probe =
      io::run_isolated([&path] { read_demo_file_in_process(path); }, kIsolatedReadSeconds);
  if (!probe.finished) {
    const std::string how =
        probe.timed_out ? "reading it took more than " + std::to_string(static_cast<int>(kIsolatedReadSeconds)) + " s"
        : probe.signal != 0 ? "reading it killed the process (signal " + std::to_string(probe.signal) + ")"
        : probe.exit_status != 0
            ? "reading it ended the process (exit status " + std::to_string(probe.exit_status) + ")"
            : "the process reading it died";
    throw DemoFileReaderDied("demo file '" + path + "': " + how + ": the file is damaged (libhdf5 " +
                             std::to_string(H5_VERS_MAJOR) + "." + std::to_string(H5_VERS_MINOR) + "." +
                             std::to_string(H5_VERS_RELEASE) + " crashes on some damaged files)");
  }
  return read_demo_file_in_process(path);
}

}  // namespace maps::envs
