#include "maps/evaluation/evaluator.h"

#include <algorithm>
#include <atomic>
#include <boost/math/distributions/students_t.hpp>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <utility>

#include "envs/env.h"
#include "envs/task_sets.h"
#include "maps/evaluation/step_actions.h"

namespace maps::core {

double t_quantile_95(int degrees_of_freedom) {
  if (degrees_of_freedom < 1)
    throw std::invalid_argument("t_quantile_95: degrees of freedom must be >= 1, got " +
                                std::to_string(degrees_of_freedom));
  return boost::math::quantile(boost::math::students_t(degrees_of_freedom), 0.975);
}

double TaskEvaluation::score_ci95() const { return episodes < 2 ? 0.0 : t_quantile_95(episodes - 1) * score_std_error; }
namespace {

using Clock = std::chrono::steady_clock;

double seconds_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

struct TaskRun {
  TaskEvaluation evaluation;
  double setup_seconds = 0.0;
  double env_seconds = 0.0;
  double policy_seconds = 0.0;
};

// Lets workers that have run out of tasks help the others step their envs. A task's owner thread still makes
// every policy call (one batch per step); only the env steps, which are independent of each other, are shared
// out. Results cannot depend on who stepped which env, so they do not depend on the thread count.
class StepHelpers {
 public:
  explicit StepHelpers(int threads) : threads_(threads), runners_(threads) {}

  // fn(i) for every i in [0, count), on this thread and on any idle worker; rethrows the first exception.
  void parallel_for(std::size_t count, const std::function<void(std::size_t)>& fn) {
    if (threads_ == 1) {
      for (std::size_t i = 0; i < count; ++i) fn(i);
      return;
    }
    auto batch = std::make_shared<Batch>(fn, count);
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      open_.push_back(batch);
    }
    changed_.notify_all();
    work_on(*batch);
    std::unique_lock<std::mutex> lock(mutex_);
    open_.erase(std::find(open_.begin(), open_.end(), batch));
    changed_.wait(lock, [&] { return batch->done == batch->count; });
    if (batch->error) std::rethrow_exception(batch->error);
  }

  // Called by a worker with no task left: helps with the open batches until every worker is out of tasks.
  void help_until_all_done() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (--runners_ == 0) changed_.notify_all();
    for (;;) {
      std::shared_ptr<Batch> batch;
      changed_.wait(lock, [&] {
        if (runners_ == 0) return true;
        for (const auto& b : open_)
          if (b->next.load() < b->count) batch = b;
        return batch != nullptr;
      });
      if (runners_ == 0) return;  // open batches belong to runners, so none is left
      lock.unlock();
      work_on(*batch);
      lock.lock();
    }
  }

 private:
  struct Batch {
    Batch(const std::function<void(std::size_t)>& f, std::size_t n) : fn(f), count(n) {}
    const std::function<void(std::size_t)>& fn;
    const std::size_t count;
    std::atomic<std::size_t> next{0};
    std::size_t done = 0;  // guarded by mutex_
    std::exception_ptr error;
  };

  void work_on(Batch& batch) {
    std::size_t finished = 0;
    std::exception_ptr error;
    for (std::size_t i = batch.next++; i < batch.count; i = batch.next++) {
      try {
        batch.fn(i);
      } catch (...) {
        if (!error) error = std::current_exception();
      }
      ++finished;
    }
    if (finished == 0) return;
    const std::lock_guard<std::mutex> lock(mutex_);
    batch.done += finished;
    if (error && !batch.error) batch.error = error;
    if (batch.done == batch.count) changed_.notify_all();
  }

  const int threads_;
  int runners_;  // workers still running tasks; guarded by mutex_
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::shared_ptr<Batch>> open_;
};

// Creates the task's envs and checks them against what the policy and the standardiser were built for, so a
// mismatch is reported before any stepping.
std::vector<std::unique_ptr<envs::Env>> make_envs(const EnvFactory& make_env, const std::string& task, int count,
                                                  const Policy& policy, const Standardizer& standardizer) {
  // Created on this thread only: concurrent make_env calls measured no faster (MuJoCo's XML loader appears to
  // serialise them), so helpers would only queue up.
  std::vector<std::unique_ptr<envs::Env>> result;
  result.reserve(static_cast<std::size_t>(count));
  for (int e = 0; e < count; ++e) {
    result.push_back(make_env(task));
    if (!result.back()) throw std::runtime_error("evaluate: the env factory returned no env for task '" + task + "'");
  }
  const envs::EnvSpec& spec = result.front()->spec();
  if (spec.observation_size != standardizer.size())
    throw std::invalid_argument("evaluate: task '" + task + "' has observations of size " +
                                std::to_string(spec.observation_size) + ", but the standardizer expects " +
                                std::to_string(standardizer.size()));
  if (spec.action_size != policy.step_action_size())
    throw std::invalid_argument("evaluate: task '" + task + "' takes actions of size " +
                                std::to_string(spec.action_size) + ", but the policy was built for " +
                                std::to_string(policy.step_action_size()));
  return result;
}

// The episodes of one task stepped together, so the policy sees one [n_running, S] batch per step. With fewer
// envs than episodes, an env whose episode ends starts the next pending one (same seed as it would have had).
// Stops early (with a partial result nobody reads) once `cancel` is set, i.e. another task failed.
TaskRun run_task(StepHelpers& helpers, const EnvFactory& make_env, Policy& policy, const Standardizer& standardizer,
                 const std::string& task, std::int64_t task_id, double expert_return, const EvalConfig& config,
                 const ModuleUsageFn* usage, const std::atomic<bool>& cancel) {
  const int episodes = config.episodes;
  const int env_count = config.max_envs_per_task > 0 ? std::min(episodes, config.max_envs_per_task) : episodes;
  const auto setup_start = Clock::now();
  std::vector<std::unique_ptr<envs::Env>> envs = make_envs(make_env, task, env_count, policy, standardizer);
  const auto obs_size = static_cast<Eigen::Index>(standardizer.size());
  const std::int64_t action_size = envs.front()->spec().action_size;

  // A wrong-sized observation would otherwise be written past the row (Eigen checks nothing in Release).
  auto check_observation = [&](const Eigen::VectorXd& o) {
    if (o.size() != obs_size)
      throw std::runtime_error("evaluate: task '" + task + "': the env returned an observation of size " +
                               std::to_string(o.size()) + ", expected " + std::to_string(obs_size));
  };
  // Row j of `obs` is the current observation of running[j], which runs on env running[j].env.
  struct Running {
    std::size_t env;
    std::size_t episode;
  };
  std::vector<Running> running;
  Eigen::MatrixXd obs(env_count, obs_size);
  // A policy predicting chunks or reading the previous state: each env's episode has its executor, and row j of
  // `prev` is the state before obs's row j (the first state itself at the start, as the demonstrations pair it).
  const chunking::ActionChunking& chunking = policy.chunking();
  const bool by_chunks = chunking.chunked();
  const bool with_history = chunking.previous_observation;
  std::vector<chunking::ChunkExecutor> executors;
  if (by_chunks) executors.assign(envs.size(), chunking::ChunkExecutor(chunking, action_size));
  Eigen::MatrixXd prev(with_history ? env_count : 0, obs_size);
  std::size_t next_episode = 0;
  auto start_episode = [&](std::size_t env, Eigen::Index row) {
    const Eigen::VectorXd first = envs[env]->reset(config.first_seed + next_episode);
    check_observation(first);
    obs.row(row) = first.transpose();
    if (with_history) prev.row(row) = first.transpose();
    if (by_chunks) executors[env] = chunking::ChunkExecutor(chunking, action_size);
    running.push_back({env, next_episode++});
  };
  for (std::size_t e = 0; e < envs.size(); ++e) start_episode(e, static_cast<Eigen::Index>(e));

  TaskRun run;
  run.setup_seconds = seconds_between(setup_start, Clock::now());
  TaskEvaluation& ev = run.evaluation;
  ev.task = task;
  ev.episodes = episodes;
  ev.returns.assign(static_cast<std::size_t>(episodes), 0.0);
  ev.successes.assign(static_cast<std::size_t>(episodes), false);
  ev.final_successes.assign(static_cast<std::size_t>(episodes), false);
  Eigen::VectorXd usage_sum;
  double entropy_sum = 0.0, top_score_sum = 0.0;
  std::int64_t usage_rows = 0;

  double unclipped_cost = 0.0;  // summed over every episode
  std::vector<envs::StepResult> steps;
  while (!running.empty() && !cancel) {
    const auto n = static_cast<std::int64_t>(running.size());
    const auto t0 = Clock::now();
    const std::vector<std::int64_t> ids(running.size(), task_id);
    ag::RowMatrixD actions;
    {
      // Thread-local: every worker needs its own guard.
      ag::NoGradGuard no_grad;
      const ag::Tensor x = standardizer.apply(obs, config.dtype);
      const ag::Tensor before = with_history ? standardizer.apply(prev, config.dtype) : x;
      std::vector<chunking::ChunkExecutor*> row_executors;
      if (by_chunks)
        for (const Running& r : running) row_executors.push_back(&executors[r.env]);
      actions = step_actions(policy, x, before, task_id, row_executors, "evaluate: task '" + task + "'");
      if (usage != nullptr) {
        const ag::Tensor u = (*usage)(x, ids);
        const bool width_ok = usage_sum.size() == 0 || (u.defined() && u.dim() == 2 && u.size(1) == usage_sum.size());
        if (!u.defined() || u.dim() != 2 || u.size(0) != n || u.size(1) < 1 || !width_ok)
          throw std::runtime_error("evaluate: task '" + task + "': the module usage function returned shape " +
                                   ag::shape_text(u) + ", expected [" + std::to_string(n) +
                                   ", M] with the same M >= 1 " + "at every step");
        const ag::RowMatrixD scores = ag::to_eigen_double(u);
        if (usage_sum.size() == 0) usage_sum = Eigen::VectorXd::Zero(scores.cols());
        usage_sum += scores.colwise().sum().transpose();
        for (Eigen::Index i = 0; i < scores.rows(); ++i) {
          for (Eigen::Index m = 0; m < scores.cols(); ++m)
            if (scores(i, m) > 0.0) entropy_sum -= scores(i, m) * std::log(scores(i, m));
          top_score_sum += scores.row(i).maxCoeff();
        }
        usage_rows += n;
      }
    }
    const auto t1 = Clock::now();

    steps.resize(running.size());
    helpers.parallel_for(running.size(), [&](std::size_t j) {
      steps[j] = envs[running[j].env]->step(actions.row(static_cast<Eigen::Index>(j)).transpose());
    });
    // Keeps the order of `running` (continuing episodes first, then new ones in seed order), so the batches are
    // a function of the config alone.
    const std::vector<Running> stepped = std::move(running);
    running.clear();
    std::vector<std::size_t> freed;
    for (std::size_t j = 0; j < stepped.size(); ++j) {
      const envs::StepResult& r = steps[j];
      ev.returns[stepped[j].episode] += r.reward;
      unclipped_cost += r.unclipped_control_cost;
      if (r.success) ev.successes[stepped[j].episode] = true;
      if (r.done()) {
        ev.final_successes[stepped[j].episode] = r.success;
        freed.push_back(stepped[j].env);
      } else {
        check_observation(r.observation);
        const auto row = static_cast<Eigen::Index>(running.size());
        if (with_history) prev.row(row) = obs.row(static_cast<Eigen::Index>(j));
        obs.row(row) = r.observation.transpose();
        running.push_back(stepped[j]);
      }
    }
    for (std::size_t env : freed) {
      if (next_episode < static_cast<std::size_t>(episodes)) {
        start_episode(env, static_cast<Eigen::Index>(running.size()));
      } else {
        envs[env].reset();  // frees the simulator early; nothing steps it again
      }
    }
    obs.conservativeResize(static_cast<Eigen::Index>(running.size()), obs_size);
    if (with_history) prev.conservativeResize(static_cast<Eigen::Index>(running.size()), obs_size);
    const auto t2 = Clock::now();
    run.policy_seconds += seconds_between(t0, t1);
    run.env_seconds += seconds_between(t1, t2);
  }

  // Per-episode scores; their spread gives the standard error of the task's score.
  const bool by_return = std::isfinite(expert_return);
  std::vector<double> scores(static_cast<std::size_t>(episodes));
  for (std::size_t e = 0; e < scores.size(); ++e)
    scores[e] = by_return ? std::max(0.0, ev.returns[e] / expert_return) : (ev.successes[e] ? 1.0 : 0.0);
  const double n = episodes;
  ev.return_mean = std::accumulate(ev.returns.begin(), ev.returns.end(), 0.0) / n;
  ev.return_mean_unclipped_cost = ev.return_mean - unclipped_cost / n;
  double return_ss = 0.0;
  for (double r : ev.returns) return_ss += (r - ev.return_mean) * (r - ev.return_mean);
  ev.return_std = std::sqrt(return_ss / n);
  ev.success_rate = static_cast<double>(std::count(ev.successes.begin(), ev.successes.end(), true)) / n;
  ev.final_success_rate =
      static_cast<double>(std::count(ev.final_successes.begin(), ev.final_successes.end(), true)) / n;
  ev.score = std::accumulate(scores.begin(), scores.end(), 0.0) / n;
  double score_ss = 0.0;
  for (double s : scores) score_ss += (s - ev.score) * (s - ev.score);
  ev.score_std_error = episodes > 1 ? std::sqrt(score_ss / (n - 1.0) / n) : 0.0;
  if (usage != nullptr) {
    ev.module_usage = usage_sum / static_cast<double>(usage_rows);
    ev.selector_entropy = entropy_sum / static_cast<double>(usage_rows);
    ev.selector_top_score = top_score_sum / static_cast<double>(usage_rows);
  }
  return run;
}

void check_arguments(const Policy& policy, const Standardizer& standardizer, const std::vector<std::string>& tasks,
                     const std::vector<double>& expert_returns, const EvalConfig& config, bool registry_tasks) {
  if (tasks.empty()) throw std::invalid_argument("evaluate: no tasks given");
  if (config.episodes < 1)
    throw std::invalid_argument("evaluate: episodes must be >= 1, got " + std::to_string(config.episodes));
  if (config.max_envs_per_task < 0)
    throw std::invalid_argument("evaluate: max_envs_per_task must be >= 0 (0: one env per episode), got " +
                                std::to_string(config.max_envs_per_task));
  if (config.threads < 0 || config.threads > ag::kMaxThreads)
    throw std::invalid_argument("evaluate: threads must be in [0, " + std::to_string(ag::kMaxThreads) +
                                "] (0: all cores), got " + std::to_string(config.threads));
  if (!expert_returns.empty() && expert_returns.size() != tasks.size())
    throw std::invalid_argument("evaluate: " + std::to_string(expert_returns.size()) + " expert returns for " +
                                std::to_string(tasks.size()) +
                                " tasks (give one per task, NaN for a task scored by success rate, or none)");
  if (!config.task_ids.empty()) {
    if (config.task_ids.size() != tasks.size())
      throw std::invalid_argument("evaluate: " + std::to_string(config.task_ids.size()) + " task ids for " +
                                  std::to_string(tasks.size()) + " tasks");
    for (std::int64_t id : config.task_ids)
      if (id < 0 || id >= policy.shape().num_tasks)
        throw std::invalid_argument("evaluate: task id " + std::to_string(id) + " is not one of the policy's " +
                                    std::to_string(policy.shape().num_tasks) + " tasks");
  }
  for (std::size_t i = 0; i < expert_returns.size(); ++i) {
    const double r = expert_returns[i];
    if (!std::isnan(r) && !(std::isfinite(r) && r > 0.0))
      throw std::invalid_argument("evaluate: task '" + tasks[i] + "': expert return must be positive and finite " +
                                  "(or NaN to score by success rate), got " + std::to_string(r));
  }
  for (const std::string& task : tasks) {
    if (!registry_tasks) break;
    try {
      envs::task_index(task);
    } catch (const std::exception& e) {
      throw std::invalid_argument(std::string("evaluate: ") + e.what());
    }
  }
  const PolicyShape& shape = policy.shape();
  if (static_cast<std::int64_t>(tasks.size()) > shape.num_tasks)
    throw std::invalid_argument("evaluate: " + std::to_string(tasks.size()) + " tasks given, but the policy was " +
                                "built for " + std::to_string(shape.num_tasks) +
                                " (task i of the list is its task id i)");
  if (standardizer.size() != shape.observation_size)
    throw std::invalid_argument("evaluate: the standardizer has " + std::to_string(standardizer.size()) +
                                " dimensions, but the policy was built for observations of size " +
                                std::to_string(shape.observation_size));
}

EvaluationResult run_evaluation(const EnvFactory& make_env, bool registry_tasks, Policy& policy,
                                const Standardizer& standardizer, const std::vector<std::string>& tasks,
                                const std::vector<double>& expert_returns, const EvalConfig& config,
                                const ModuleUsageFn* usage, const EvalProgressFn& progress) {
  check_arguments(policy, standardizer, tasks, expert_returns, config, registry_tasks);
  const auto start = Clock::now();
  const int hardware = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  // More threads than tasks is useful: the extra ones step the envs of the tasks in progress.
  const int threads = config.threads > 0 ? config.threads : std::min(hardware, ag::kMaxThreads);

  std::vector<TaskRun> runs(tasks.size());
  std::vector<std::exception_ptr> errors(tasks.size());
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex progress_mutex;
  StepHelpers helpers(threads);
  auto worker = [&] {
    for (std::size_t i = next++; i < tasks.size() && !failed; i = next++) {
      try {
        const double expert = expert_returns.empty() ? std::nan("") : expert_returns[i];
        const std::int64_t id = config.task_ids.empty() ? static_cast<std::int64_t>(i) : config.task_ids[i];
        runs[i] = run_task(helpers, make_env, policy, standardizer, tasks[i], id, expert, config, usage, failed);
        if (progress && !failed) {
          const std::lock_guard<std::mutex> lock(progress_mutex);
          progress(i, runs[i].evaluation);
        }
      } catch (...) {
        errors[i] = std::current_exception();
        failed = true;  // the other workers stop at their next step
      }
    }
    helpers.help_until_all_done();
  };
  if (threads == 1) {
    worker();  // no thread at all: a policy that is not thread-safe is then safe to evaluate
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
    for (auto& thread : pool) thread.join();
  }
  for (const auto& error : errors)
    if (error) std::rethrow_exception(error);

  EvaluationResult result;
  for (TaskRun& run : runs) {
    result.setup_seconds += run.setup_seconds;
    result.env_seconds += run.env_seconds;
    result.policy_seconds += run.policy_seconds;
    result.mean_score += run.evaluation.score / static_cast<double>(runs.size());
    result.tasks.push_back(std::move(run.evaluation));
  }
  result.seconds = seconds_between(start, Clock::now());
  return result;
}

}  // namespace

EvaluationResult evaluate(Policy& policy, const Standardizer& standardizer, const std::vector<std::string>& tasks,
                          const std::vector<double>& expert_returns, const EvalConfig& config,
                          const ModuleUsageFn* usage, const EvalProgressFn& progress) {
  const EnvFactory registry = [](const std::string& task) { return envs::make_env(task); };
  return run_evaluation(registry, true, policy, standardizer, tasks, expert_returns, config, usage, progress);
}

EvaluationResult evaluate_with_envs(const EnvFactory& make_env, Policy& policy, const Standardizer& standardizer,
                                    const std::vector<std::string>& tasks, const std::vector<double>& expert_returns,
                                    const EvalConfig& config, const ModuleUsageFn* usage,
                                    const EvalProgressFn& progress) {
  if (!make_env) throw std::invalid_argument("evaluate_with_envs: no env factory given");
  return run_evaluation(make_env, false, policy, standardizer, tasks, expert_returns, config, usage, progress);
}

}  // namespace maps::core
