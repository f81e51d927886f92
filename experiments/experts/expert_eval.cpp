// `maps expert-eval`: what each task's expert scores, measured the same way for every set.

#include "experiments/experts/expert_eval.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "envs/expert_evaluation.h"
#include "envs/task_expert.h"
#include "envs/task_sets.h"
#include "experiments/process/host.h"
#include "experiments/process/parallel_tasks.h"
#include "io/output_files.h"

namespace maps::experiments {
namespace {

envs::ExpertEpisodes evaluate(const std::string& task, int episodes, std::uint64_t first_seed) {
  auto env = envs::make_env(task);
  return envs::run_expert(*env, envs::load_task_expert(task), episodes, first_seed);
}

double mean_first_success(const envs::ExpertEpisodes& e) {
  double total = 0.0;
  int count = 0;
  for (int step : e.first_success_steps)
    if (step >= 0) total += step, ++count;
  return count > 0 ? total / count : -1.0;
}

}  // namespace

int run_expert_eval(const ExpertEvalOptions& options) {
  if (options.task_set.empty() == options.task.empty())
    throw std::invalid_argument("give exactly one of --set and --task");
  if (options.episodes < 1) throw std::invalid_argument("--episodes: must be >= 1");
  const std::vector<std::string> tasks =
      options.task.empty() ? envs::task_names(options.task_set) : std::vector<std::string>{options.task};
  for (const auto& task : tasks) envs::task_index(task);  // an unknown task fails here, before any work
  if (!options.out.empty()) io::check_output_file("--out", options.out);
  const int threads = worker_count(options.threads, tasks.size());
  // With --json, stdout holds only the JSON; the words go to stderr.
  std::FILE* text = options.json ? stderr : stdout;
  std::fprintf(text, "maps expert-eval: %zu tasks, %d episodes each from seed %llu (mean actions), %d threads\n",
               tasks.size(), options.episodes, static_cast<unsigned long long>(options.first_seed), threads);
  std::fflush(text);

  const auto start = std::chrono::steady_clock::now();
  std::vector<envs::ExpertEpisodes> scores(tasks.size());
  run_tasks_in_parallel(tasks.size(), threads,
                        [&](std::size_t i) { scores[i] = evaluate(tasks[i], options.episodes, options.first_seed); });

  std::fprintf(text, "| task | return (mean +- std) | success | mean first-success step | failed (turned over) |\n");
  std::fprintf(text, "|---|---|---|---|---|\n");
  nlohmann::json table = nlohmann::json::array();
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const envs::ExpertEpisodes& s = scores[i];
    const double first = mean_first_success(s);
    std::fprintf(text, "| %s | %.1f +- %.1f | %d / %d | %s | %d / %d |\n", tasks[i].c_str(), s.mean_return(),
                 s.return_std(), s.success_count(), options.episodes,
                 first >= 0 ? std::to_string(static_cast<int>(std::lround(first))).c_str() : "-", s.failed_count(),
                 options.episodes);
    table.push_back({{"task", tasks[i]},
                     {"episodes", options.episodes},
                     {"first_seed", options.first_seed},
                     {"return_mean", s.mean_return()},
                     {"return_std", s.return_std()},
                     {"return_mean_unclipped_cost", s.mean_return_unclipped_cost()},
                     {"success_rate", static_cast<double>(s.success_count()) / options.episodes},
                     {"mean_first_success_step", first},
                     {"failed_episodes", s.failed_count()}});
  }
  std::fprintf(text, "took %.1f s\n", seconds_since(start));
  if (options.json) std::printf("%s\n", table.dump().c_str());
  if (!options.out.empty()) {
    std::ofstream out(options.out);
    out << table.dump(2) << "\n";
    if (!out) throw std::runtime_error("cannot write '" + options.out + "'");
  }
  return 0;
}

}  // namespace maps::experiments
