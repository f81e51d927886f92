#pragma once

#include <cstdint>
#include <string>

// curve.csv's rows on resumption (the BC trainer's and GAIL's): a row per validation or iteration, its first column
// the step or iteration number.
namespace maps::core {

// Keeps the header and the whole rows whose first column is at most `step` (the rows a resumed run will not write
// again); rows cut short by a kill mid-append are dropped. A missing file is left missing. Rewritten through a
// temporary and a rename: a kill during the rewrite must leave the old curve, not an empty one (CI once saw a run
// killed there resume into a curve that began at step 1350). A first column that is not a whole number is an error
// naming the file and line.
void truncate_curve(const std::string& path, std::int64_t step);

// Whether curve.csv's rows carry cpu_seconds as their last column: a fresh (missing or empty) curve does; one begun by
// a build from before the column (a resumed older run) keeps its header's columns.
bool curve_has_cpu_column(const std::string& path);

// CPU time of the whole process (every thread): the cost of a window of steps or an iteration whatever else shares
// the cores, and which does not grow while the process is stopped (SIGSTOP) as wall time does.
double process_cpu_seconds();

}  // namespace maps::core
