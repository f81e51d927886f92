#pragma once

#include <cstdint>
#include <functional>

// The threads ops may use. Off by default (one thread): a tool opts in (`maps bench step --threads 2`, a run
// config's "threads"), because the evaluator and the grid scripts already run whole tasks and runs side by side.
// Eigen's own GEMM threading is off (EIGEN_DONT_PARALLELIZE, set for the whole build): ops split their work here.
namespace maps::ag {

// The most threads any tool starts for one job (ops, the evaluator, rollouts): a count beyond it is a typo (a
// billion threads ended in std::terminate when the system refused to make them), and more threads than the
// machine's cores only add overhead.
inline constexpr int kMaxThreads = 256;

// Sets the threads ops use from now on (1 to kMaxThreads).
void set_num_threads(int threads);
int num_threads();

// Calls body(begin, end) on disjoint, contiguous ranges covering [0, count), on up to num_threads() threads, each
// range at least `grain` long (one range, on the calling thread, when count < 2 grain or when called from inside
// another parallel_for). The first exception a range throws is rethrown here once every range has finished.
void parallel_for(std::int64_t count, std::int64_t grain, const std::function<void(std::int64_t, std::int64_t)>& body);

// The ranges parallel_for(count, grain, ...) uses now: 0 for an empty count, 1 inside another parallel_for.
std::int64_t parallel_ranges(std::int64_t count, std::int64_t grain);
// Calls body(range, begin, end) for range = 0 .. ranges - 1 (at most count), range r covering
// [count r / ranges, count (r + 1) / ranges), on up to `ranges` threads. For per-range partial results: allocate
// one slot per range from parallel_ranges() and add them in range order afterwards, which keeps sums the same from
// run to run. Exceptions as parallel_for.
void parallel_for_ranges(std::int64_t count, std::int64_t ranges,
                         const std::function<void(std::int64_t, std::int64_t, std::int64_t)>& body);

}  // namespace maps::ag
