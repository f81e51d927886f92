#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "envs/env.h"
#include "envs/seed_ranges.h"
#include "maps/data/standardizer.h"
#include "maps/policies/policy.h"

// Rolls a trained policy out on held-out initial states and scores it the way the paper reports it:
// HalfCheetah sets by return normalised with the expert's return, MT10 by success rate.
namespace maps::core {

struct EvalConfig {
  int episodes = 100;                               // per task, from seeds first_seed, first_seed + 1, ...
  std::uint64_t first_seed = envs::kEvalSeedBegin;  // evaluation seeds never overlap demonstration seeds
  // Tasks run concurrently; threads beyond the task count help step envs. 0: hardware_concurrency; 1: all on the
  // calling thread.
  int threads = 0;
  ag::Dtype dtype = ag::Dtype::Float32;  // of the observations handed to the policy
  // Envs alive per task at once (0: one per episode, all stepped together). An env whose episode ends starts the
  // next pending one, so the policy sees batches of up to this many rows. Fewer envs mostly save building them:
  // an MT10 env held ~48 MB and took ~50-80 ms to build while its model asked for njmax 2000, which made 100 envs
  // per task 5x slower overall than 10 (MT10, 100 episodes: 101 s and 4.8 GB per thread vs 18 s and 0.5 GB). Since
  // njmax 500 an MT10 env takes ~10 MB and ~0.6 ms; HalfCheetah (~3 MB, ~1 ms per env) ran as fast with 10 as with
  // 100 (env steps take 95% of the time either way).
  int max_envs_per_task = 10;
  // The policy's task id of each task in the list evaluate() gets (empty: its position in the list), so that some
  // of a policy's tasks can be evaluated alone.
  std::vector<std::int64_t> task_ids;
};

struct TaskEvaluation {
  std::string task;
  int episodes = 0;
  double return_mean = 0.0;
  double return_std = 0.0;          // population std over episodes
  double success_rate = 0.0;        // share of episodes where the task's success test held at some step
  double final_success_rate = 0.0;  // share where it held at the episode's last step (another reading of success)
  double score = 0.0;               // mean over episodes of max(0, return / expert return), or the success rate
  double score_std_error = 0.0;     // sample std of the per-episode scores / sqrt(episodes); 0 for one episode
  std::vector<double> returns;      // per episode, in seed order
  // The mean return with Gym's control cost on the unclipped action (StepResult::unclipped_control_cost): equal
  // to return_mean for MT10 and for policies whose actions stay in bounds. Scores use return_mean.
  double return_mean_unclipped_cost = 0.0;
  std::vector<bool> successes;
  std::vector<bool> final_successes;  // the success test at each episode's last step
  // Mean selector score of each module over every state visited in this task's episodes; empty unless a
  // ModuleUsageFn was given.
  Eigen::VectorXd module_usage;
  // How decisively the selector routes each state (the usage above is a mean over states, so it is uniform both
  // when every state mixes all modules and when each state picks one module but different states pick different
  // ones): the mean over visited states of the entropy (nats) of that state's scores, and of its largest score.
  // 0 unless a ModuleUsageFn was given. Uniform over M modules: log M and 1/M; one module per state: 0 and 1.
  double selector_entropy = 0.0;
  double selector_top_score = 0.0;

  // Half-width of the 95% confidence interval of `score`: Student's t quantile for episodes - 1 degrees of freedom
  // times the standard error (0 for one episode), as the suite's report computes its intervals.
  double score_ci95() const;
};

struct EvaluationResult {
  std::vector<TaskEvaluation> tasks;  // in the order of the task list
  double mean_score = 0.0;            // unweighted mean of the tasks' scores
  double seconds = 0.0;               // wall time of the whole evaluation
  // Where the time went, summed over tasks (each measured on the thread running the task, helpers included):
  // creating and resetting the envs, stepping them, and standardising + the policy (+ usage) calls.
  double setup_seconds = 0.0;
  double env_seconds = 0.0;
  double policy_seconds = 0.0;
};

// The two-sided 95% quantile of Student's t distribution (12.706 for 1 degree of freedom, 1.984 for 99).
double t_quantile_95(int degrees_of_freedom);

// Selector scores [n, M] for standardised observations [n, S] of the given tasks (MAPS's module usage).
using ModuleUsageFn = std::function<ag::Tensor(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks)>;
// Called once per finished task (index in the task list), from a worker thread but never concurrently.
using EvalProgressFn = std::function<void(std::size_t task_index, const TaskEvaluation& evaluation)>;

// Runs config.episodes episodes of every task, the running episodes of one task stepped together: one policy.act
// call per step for the whole batch, under ag::NoGradGuard. Task i of `tasks` is task id i for
// the policy. `expert_returns` holds one normaliser per task (NaN: score that task by success rate), or is empty
// (every task by success rate). Episode e of every task starts from seed first_seed + e, and a task's batches
// are the same whatever the thread count, so results are bit-identical for any thread count. They may differ in the
// last digits with `episodes` or `max_envs_per_task`: the engine's float32 matrix products round a row differently in
// batches of other sizes (measured: a random 3x128 MLP's gravity/1.0 return moved by 2e-7 relative between 1 and 2
// episodes), and a long rollout can amplify that.
//
// Tasks run on separate threads, each with its own envs, calling policy.act (and `usage`) concurrently: both
// must only read shared state (true of the autograd engine and nn layers without grad; a policy caching into
// members must be run with threads = 1). Threads without a task of their own help step the envs
// of the tasks in progress, so even one task uses every core; the owner thread alone calls the policy.
EvaluationResult evaluate(Policy& policy, const Standardizer& standardizer, const std::vector<std::string>& tasks,
                          const std::vector<double>& expert_returns, const EvalConfig& config,
                          const ModuleUsageFn* usage = nullptr, const EvalProgressFn& progress = {});

// A new env for a task name (envs::make_env by default).
using EnvFactory = std::function<std::unique_ptr<envs::Env>(const std::string& task)>;
// evaluate() with envs from `make_env` instead of the task registry (tests use toy envs whose episodes end at
// different steps; the real sets all run to their horizon). Task names are not checked against the registry.
EvaluationResult evaluate_with_envs(const EnvFactory& make_env, Policy& policy, const Standardizer& standardizer,
                                    const std::vector<std::string>& tasks, const std::vector<double>& expert_returns,
                                    const EvalConfig& config, const ModuleUsageFn* usage = nullptr,
                                    const EvalProgressFn& progress = {});

}  // namespace maps::core
