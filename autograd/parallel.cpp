#include "autograd/parallel.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>

#include "autograd/float_environment.h"
#include "autograd/matmul_precision.h"

namespace maps::ag {
namespace {

std::atomic<int> g_threads{1};

}  // namespace

void set_num_threads(int threads) {
  if (threads < 1 || threads > kMaxThreads)
    throw std::invalid_argument("set_num_threads: threads must be in [1, " + std::to_string(kMaxThreads) + "], got " +
                                std::to_string(threads));
  g_threads.store(threads);
}

int num_threads() { return g_threads.load(); }

std::int64_t parallel_ranges(std::int64_t count, std::int64_t grain) {
  if (count <= 0) return 0;
  if (omp_in_parallel()) return 1;
  return std::max<std::int64_t>(1, std::min<std::int64_t>(num_threads(), count / std::max<std::int64_t>(grain, 1)));
}

void parallel_for_ranges(std::int64_t count, std::int64_t ranges,
                         const std::function<void(std::int64_t, std::int64_t, std::int64_t)>& body) {
  if (count <= 0 || ranges <= 0) return;
  ranges = std::min(ranges, count);
  if (ranges == 1 || omp_in_parallel()) {
    for (std::int64_t r = 0; r < ranges; ++r) body(r, count * r / ranges, count * (r + 1) / ranges);
    return;
  }
  std::exception_ptr error;
  std::mutex error_mutex;
  // The threads compute as the caller does (flushing denormals or not, the products' precision: both per thread).
  const unsigned denormal_bits = detail::denormal_bits();
  const MatmulPrecision precision = matmul_precision();
#pragma omp parallel num_threads(static_cast <int>(ranges))
  {
    detail::set_denormal_bits(denormal_bits);
    set_matmul_precision(precision);
    // OpenMP may start fewer threads than asked for: then a thread takes several ranges.
    const std::int64_t used = omp_get_num_threads();
    for (std::int64_t r = omp_get_thread_num(); r < ranges; r += used) {
      try {
        body(r, count * r / ranges, count * (r + 1) / ranges);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  }
  if (error) std::rethrow_exception(error);
}

void parallel_for(std::int64_t count, std::int64_t grain, const std::function<void(std::int64_t, std::int64_t)>& body) {
  parallel_for_ranges(count, parallel_ranges(count, grain),
                      [&](std::int64_t, std::int64_t begin, std::int64_t end) { body(begin, end); });
}

}  // namespace maps::ag
