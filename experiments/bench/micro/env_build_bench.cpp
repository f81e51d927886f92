// How long building an env takes (XML compile, mj_makeData, the task's setup), per task set: the evaluator builds
// envs for every task of a run, and MT10's once cost ~47 ms each (docs/mt10.md, njmax). The time column is per
// iteration, which builds one env of every task of the set.
//
//   maps_bench --benchmark_filter=EnvBuild
#include <benchmark/benchmark.h>

#include <string>

#include "envs/task_sets.h"

namespace {

void build_every_task(benchmark::State& state, const std::string& task_set) {
  const auto tasks = maps::envs::task_names(task_set);
  for (auto _ : state)
    for (const auto& task : tasks) benchmark::DoNotOptimize(maps::envs::make_env(task));
  state.counters["envs_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * tasks.size()), benchmark::Counter::kIsRate);
}

void BM_EnvBuildMT10(benchmark::State& state) { build_every_task(state, "mt10"); }
void BM_EnvBuildGravity(benchmark::State& state) { build_every_task(state, "gravity"); }

BENCHMARK(BM_EnvBuildMT10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EnvBuildGravity)->Unit(benchmark::kMillisecond);

}  // namespace
