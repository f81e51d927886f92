#include "experiments/process/parallel_tasks.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

#include "autograd/parallel.h"

namespace maps::experiments {

int worker_count(int requested, std::size_t tasks) {
  const int wanted =
      requested > 0 ? requested : std::min(static_cast<int>(std::thread::hardware_concurrency()), ag::kMaxThreads);
  return std::clamp(wanted, 1, std::max(1, static_cast<int>(tasks)));
}

void run_tasks_in_parallel(std::size_t count, int threads, const std::function<void(std::size_t)>& work) {
  std::vector<std::exception_ptr> errors(count);
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&] {
      for (std::size_t i = next++; i < count; i = next++) {
        try {
          work(i);
        } catch (...) {
          errors[i] = std::current_exception();
        }
      }
    });
  }
  for (auto& thread : pool) thread.join();
  for (const auto& error : errors)
    if (error) std::rethrow_exception(error);
}

}  // namespace maps::experiments
