// `maps collect`: demonstrations of a task set from the committed experts.

#include "experiments/experts/collect.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "envs/demo_collection.h"
#include "envs/mujoco_env.h"
#include "envs/source_folders.h"
#include "envs/task_sets.h"
#include "experiments/process/host.h"
#include "experiments/process/parallel_tasks.h"
#include "experiments/process/plugins.h"
#include "io/output_files.h"

namespace maps::experiments {
namespace {

// Every task's expert, or one error listing all that are missing.
std::vector<envs::TaskExpert> load_experts(const std::vector<std::string>& tasks, const std::string& experts_dir) {
  std::vector<envs::TaskExpert> experts;
  std::string missing;
  int missing_count = 0;
  for (const auto& task : tasks) {
    try {
      experts.push_back(envs::load_task_expert(task, experts_dir));
    } catch (const std::exception& e) {
      missing += std::string("\n  ") + e.what();
      ++missing_count;
    }
  }
  if (missing_count > 0)
    throw std::runtime_error(std::to_string(missing_count) + " of " + std::to_string(tasks.size()) +
                             " experts could not be loaded:" + missing);
  return experts;
}

}  // namespace

int run_collect(const CollectOptions& options) {
  for (const std::string& plugin : options.plugins) load_plugin(plugin, "--plugin");
  const std::vector<std::string> tasks = envs::task_names(options.task_set);
  if (options.demos < 2) throw std::invalid_argument("--demos: a train/valid split needs at least 2 per task");
  if (!(options.train_fraction > 0.0 && options.train_fraction < 1.0))
    throw std::invalid_argument("--train-fraction: must be in (0, 1)");
  if (std::filesystem::is_regular_file(options.out) && !options.force)
    throw std::invalid_argument("--out " + options.out +
                                " already exists: pass --force to replace it (runs trained on it would no longer "
                                "match it)");
  io::check_output_file("--out", options.out);
  envs::DemoCollectionConfig config;
  config.demos = options.demos;
  config.actions = envs::parse_demo_actions(options.actions);
  config.first_seed = options.first_seed;
  config.min_return_fraction = options.min_return_fraction;
  if (envs::scored_by_success(options.task_set)) {
    // MT10's reward counts the steps at which the success test holds: demonstrations must succeed, and how long
    // after success an episode runs says nothing of its quality (so for any set scored by success).
    config.require_success = true;
    config.min_return_fraction = 0.0;
  }
  const std::vector<envs::TaskExpert> experts = load_experts(tasks, options.experts_dir);

  const int threads = worker_count(options.threads, tasks.size());
  std::printf("maps collect: %s set, %zu tasks, %d demos each (%s actions), seeds from %llu, %d threads\n",
              options.task_set.c_str(), tasks.size(), options.demos, options.actions.c_str(),
              static_cast<unsigned long long>(options.first_seed), threads);
  std::fflush(stdout);

  const auto start = std::chrono::steady_clock::now();
  std::vector<envs::TaskDemonstrations> results(tasks.size());
  std::atomic<int> finished{0};
  std::mutex print_mutex;
  run_tasks_in_parallel(tasks.size(), threads, [&](std::size_t i) {
    auto env = envs::make_env(tasks[i]);
    results[i] = envs::collect_task_demonstrations(*env, experts[i], config);
    double mean = 0.0;
    for (const auto& d : results[i].demos) mean += d.episode_return / results[i].demos.size();
    const std::lock_guard<std::mutex> lock(print_mutex);
    const double documented = experts[i].documented_return;
    const std::string expert_part =
        std::isfinite(documented) ? ", expert's documented " + std::to_string(std::lround(documented)) : "";
    std::printf("[%2d/%zu] %-26s %zu demos, return %.1f (median %.1f%s), %zu discarded, %.0f s\n", ++finished,
                tasks.size(), tasks[i].c_str(), results[i].demos.size(), mean, results[i].median_return,
                expert_part.c_str(), results[i].discarded.size(), seconds_since(start));
    std::fflush(stdout);
  });

  envs::DemoFile file;
  file.task_set = options.task_set;
  file.task_names = tasks;
  file.env_version = envs::mujoco_env_version();
  file.creation_command = options.command_line;
  nlohmann::json per_task = nlohmann::json::object();
  int discarded_total = 0;
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const int offset = static_cast<int>(file.demos.size());
    auto [train, valid] = envs::split_train_valid(options.demos, options.train_fraction, options.split_seed + i);
    for (int k : train) file.train.push_back(offset + k);
    for (int k : valid) file.valid.push_back(offset + k);
    nlohmann::json discarded = nlohmann::json::array();
    for (const auto& d : results[i].discarded)
      discarded.push_back({{"seed", d.seed}, {"return", d.episode_return}, {"reason", d.reason}});
    std::vector<std::uint64_t> seeds;
    for (auto& demo : results[i].demos) {
      seeds.push_back(demo.seed);
      file.demos.push_back(std::move(demo));
    }
    discarded_total += static_cast<int>(results[i].discarded.size());
    per_task[tasks[i]] = {{"expert_eval_return_mean", experts[i].documented_return},
                          {"median_return", results[i].median_return},
                          {"seeds", seeds},
                          {"discarded", discarded}};
  }
  std::sort(file.train.begin(), file.train.end());
  std::sort(file.valid.begin(), file.valid.end());
  file.extra_json = nlohmann::json{
      {"actions", options.actions},
      {"demos_per_task", options.demos},
      {"first_seed", options.first_seed},
      {"eval_seed_begin", envs::kEvalSeedBegin},
      {"min_return_fraction", options.min_return_fraction},
      {"max_failure_fraction", config.max_failure_fraction},
      {"train_fraction", options.train_fraction},
      {"split",
       "per task, envs::split_train_valid(demos, train_fraction, split_seed + "
       "task_index)"},
      {"split_seed", options.split_seed},
      {"discarded_total", discarded_total},
      {"tasks",
       per_task}}.dump();
  // The demo file's folder is made if missing (data/ is not in a fresh clone: its files are regenerated).
  const std::filesystem::path parent = std::filesystem::path(options.out).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  envs::write_demo_file(options.out, file);
  std::printf("wrote %s: %zu demos (%zu train, %zu valid), %lld samples, %d episodes discarded, %.0f s\n",
              options.out.c_str(), file.demos.size(), file.train.size(), file.valid.size(),
              static_cast<long long>(file.total_samples()), discarded_total, seconds_since(start));
  return 0;
}

}  // namespace maps::experiments
