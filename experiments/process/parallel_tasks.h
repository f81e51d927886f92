#pragma once

#include <cstddef>
#include <functional>

// Independent per-task work (collecting demos, scoring experts) spread over threads.
namespace maps::experiments {

// `requested` threads (0: one per core), at least 1 and no more than there are tasks.
int worker_count(int requested, std::size_t tasks);

// Calls work(i) for i in [0, count) on `threads` threads, each taking the next index as it finishes one. An
// exception does not stop the other tasks; after all have run, the first in index order is rethrown.
void run_tasks_in_parallel(std::size_t count, int threads, const std::function<void(std::size_t)>& work);

}  // namespace maps::experiments
