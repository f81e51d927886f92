// `maps collect`: demonstrations of a task set from the committed experts.

#include "experiments/collect.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "envs/demo_collection.h"
#include "envs/mujoco_env.h"
#include "envs/source_folders.h"
#include "envs/task_sets.h"

namespace maps::experiments {
namespace {

std::vector<envs::ExpertPolicy> load_experts(const std::vector<std::string>& tasks, const std::string& experts_dir) {
  const std::filesystem::path dir = experts_dir.empty() ? envs::experts_dir() : std::filesystem::path(experts_dir);
  std::vector<std::string> missing;
  for (const auto& task : tasks)
    if (!std::filesystem::is_regular_file(dir / (task + ".json"))) missing.push_back((dir / (task + ".json")).string());
  if (!missing.empty()) {
    std::string message = std::to_string(missing.size()) + " of " + std::to_string(tasks.size()) +
                          " experts are missing (train them with `maps train-expert`):";
    for (const auto& path : missing) message += " " + path;
    throw std::runtime_error(message);
  }
  std::vector<envs::ExpertPolicy> experts;
  for (const auto& task : tasks) {
    experts.push_back(envs::ExpertPolicy::load((dir / (task + ".json")).string()));
    if (experts.back().task != task)
      throw std::runtime_error("expert file " + (dir / (task + ".json")).string() + " holds an expert of '" +
                               experts.back().task + "', not '" + task + "'");
  }
  return experts;
}

double documented_return(const envs::ExpertPolicy& expert) {
  const auto metadata = nlohmann::json::parse(expert.metadata_json, nullptr, /*allow_exceptions=*/false);
  if (metadata.is_object() && metadata.contains("eval_return_mean") && metadata["eval_return_mean"].is_number())
    return metadata["eval_return_mean"].get<double>();
  return std::nan("");
}

}  // namespace

int run_collect(const CollectOptions& options) {
  const std::vector<std::string> tasks = envs::task_names(options.task_set);
  if (options.demos < 2) throw std::invalid_argument("--demos: a train/valid split needs at least 2 per task");
  if (!(options.train_fraction > 0.0 && options.train_fraction < 1.0))
    throw std::invalid_argument("--train-fraction: must be in (0, 1)");
  envs::DemoCollectionConfig config;
  config.demos = options.demos;
  config.actions = envs::parse_demo_actions(options.actions);
  config.first_seed = options.first_seed;
  config.min_return_fraction = options.min_return_fraction;
  const std::vector<envs::ExpertPolicy> experts = load_experts(tasks, options.experts_dir);

  const int threads =
      std::clamp(options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency()), 1,
                 static_cast<int>(tasks.size()));
  std::printf("maps collect: %s set, %zu tasks, %d demos each (%s actions), seeds from %llu, %d threads\n",
              options.task_set.c_str(), tasks.size(), options.demos, options.actions.c_str(),
              static_cast<unsigned long long>(options.first_seed), threads);
  std::fflush(stdout);

  const auto start = std::chrono::steady_clock::now();
  std::vector<envs::TaskDemonstrations> results(tasks.size());
  std::vector<std::exception_ptr> errors(tasks.size());
  std::atomic<std::size_t> next{0};
  std::atomic<int> finished{0};
  std::mutex print_mutex;
  const auto work = [&] {
    for (std::size_t i = next++; i < tasks.size(); i = next++) {
      try {
        auto env = envs::make_env(tasks[i]);
        results[i] = envs::collect_task_demonstrations(*env, experts[i], config);
        double mean = 0.0;
        for (const auto& d : results[i].demos) mean += d.episode_return / results[i].demos.size();
        const std::lock_guard<std::mutex> lock(print_mutex);
        std::printf("[%2d/%zu] %-22s return %7.1f (median %7.1f, expert %7.1f), %zu discarded, %.0f s\n", ++finished,
                    tasks.size(), tasks[i].c_str(), mean, results[i].median_return, documented_return(experts[i]),
                    results[i].discarded.size(),
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        std::fflush(stdout);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  for (auto& thread : pool) thread.join();
  for (const auto& error : errors)
    if (error) std::rethrow_exception(error);

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
    per_task[tasks[i]] = {{"expert_eval_return_mean", documented_return(experts[i])},
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
  envs::write_demo_file(options.out, file);
  std::printf("wrote %s: %zu demos (%zu train, %zu valid), %lld samples, %d episodes discarded, %.0f s\n",
              options.out.c_str(), file.demos.size(), file.train.size(), file.valid.size(),
              static_cast<long long>(file.total_samples()), discarded_total,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return 0;
}

}  // namespace maps::experiments
