#pragma once

#include <filesystem>
#include <string>
#include <vector>

// Child programs: the suite's cells (this binary again), the report and the format converters (python3).
namespace maps::experiments {

// Runs `program` (a path) with `args`, its stdout and stderr appended to `log` (nullptr: this process's); the
// child is killed when the calling thread dies. Returns the exit code (128 + signal when killed by one; 127 when
// it could not be started).
int run_program(const std::string& program, const std::vector<std::string>& args, const std::filesystem::path* log);
// run_program on this binary (/proc/self/exe: the same build for the whole suite, even if build/ is rebuilt).
int run_self(const std::vector<std::string>& args, const std::filesystem::path& log);

// The last `lines` lines of a text file ("" when missing).
std::string tail_of(const std::filesystem::path& path, int lines);
// The last non-empty line of a log: what a failed child said last ("maps: error: ...").
std::string last_line(const std::filesystem::path& log);

}  // namespace maps::experiments
