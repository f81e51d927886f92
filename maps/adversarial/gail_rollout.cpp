#include "maps/adversarial/gail_rollout.h"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "autograd/parallel.h"

namespace maps::adversarial {
namespace {

// One episode's rows while it runs (float32 rows, as the policy sees them).
struct EpisodeBuffer {
  std::vector<float> observations, previous_observations, actions, executed;
  std::vector<double> log_probs, rewards;
  Eigen::VectorXf current, previous;  // standardised
  Eigen::VectorXf final_observation;
  bool terminated = false, success = false;
  double env_return = 0.0;
};

void append(std::vector<float>& rows, const Eigen::VectorXf& row) {
  rows.insert(rows.end(), row.data(), row.data() + row.size());
}

}  // namespace

Rollout collect_rollout(const std::vector<std::unique_ptr<envs::Env>>& envs, const std::vector<std::int64_t>& env_tasks,
                        const std::vector<std::uint64_t>& seeds, core::Policy& policy, const ag::Tensor& log_std,
                        const core::Standardizer& standardizer, std::int64_t num_tasks, ag::Generator& noise,
                        RolloutTimes& times) {
  const std::size_t count = envs.size();
  if (env_tasks.size() != count || seeds.size() != count || count == 0)
    throw std::invalid_argument("collect_rollout: expected as many tasks and seeds as envs (at least one)");
  const std::int64_t S = standardizer.size();
  const std::int64_t A = log_std.numel();
  const Eigen::VectorXd stds = ag::to_eigen_double(log_std.detach()).reshaped().array().exp();
  const double log_std_sum = stds.array().log().sum();
  const double log_norm = 0.5 * std::log(2.0 * M_PI) * static_cast<double>(A);

  std::vector<EpisodeBuffer> episodes(count);
  auto start = std::chrono::steady_clock::now();
  std::vector<Eigen::VectorXd> raw(count);
  ag::parallel_for(static_cast<std::int64_t>(count), 1, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t i = begin; i < end; ++i) raw[i] = envs[i]->reset(seeds[i]);
  });
  times.physics_seconds += seconds_since(start);
  for (std::size_t i = 0; i < count; ++i) {
    if (raw[i].size() != S)
      throw std::invalid_argument("collect_rollout: task " + envs[i]->spec().task + " observes " +
                                  std::to_string(raw[i].size()) + " values, the demonstrations " + std::to_string(S));
    if (envs[i]->spec().action_size != A)
      throw std::invalid_argument("collect_rollout: task " + envs[i]->spec().task + " takes " +
                                  std::to_string(envs[i]->spec().action_size) + " actions, the policy gives " +
                                  std::to_string(A));
    episodes[i].current = standardizer.apply(raw[i]).cast<float>();
    episodes[i].previous = episodes[i].current;
  }

  std::vector<std::size_t> running(count);
  for (std::size_t i = 0; i < count; ++i) running[i] = i;
  std::vector<envs::StepResult> results(count);
  std::vector<Eigen::VectorXd> actions(count);
  while (!running.empty()) {
    start = std::chrono::steady_clock::now();
    const auto n = static_cast<std::int64_t>(running.size());
    ag::RowMatrixF observations(n, S);
    std::vector<std::int64_t> tasks(running.size());
    for (std::int64_t j = 0; j < n; ++j) {
      observations.row(j) = episodes[running[j]].current.transpose();
      tasks[j] = env_tasks[running[j]];
    }
    ag::RowMatrixD means;
    {
      ag::NoGradGuard no_grad;
      means = ag::to_eigen_double(policy.act(ag::from_eigen(observations), tasks));
    }
    for (std::int64_t j = 0; j < n; ++j) {
      const std::size_t i = running[j];
      if (!means.row(j).allFinite())
        throw std::runtime_error("GAIL rollout: the policy's mean action for task " + envs[i]->spec().task +
                                 " is not finite");
      Eigen::VectorXd action(A);
      double squared = 0.0;
      for (std::int64_t d = 0; d < A; ++d) {
        const double z = noise.normal();
        action(d) = means(j, d) + stds(d) * z;
        squared += z * z;
      }
      actions[i] = std::move(action);
      episodes[i].log_probs.push_back(-0.5 * squared - log_std_sum - log_norm);
    }
    times.policy_seconds += seconds_since(start);
    start = std::chrono::steady_clock::now();
    ag::parallel_for(n, 1, [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t j = begin; j < end; ++j) results[running[j]] = envs[running[j]]->step(actions[running[j]]);
    });
    times.physics_seconds += seconds_since(start);
    std::vector<std::size_t> still;
    for (const std::size_t i : running) {
      EpisodeBuffer& e = episodes[i];
      const envs::EnvSpec& spec = envs[i]->spec();
      append(e.observations, e.current);
      append(e.previous_observations, e.previous);
      append(e.actions, actions[i].cast<float>());
      append(e.executed, actions[i].cwiseMax(spec.action_low).cwiseMin(spec.action_high).cast<float>());
      e.rewards.push_back(results[i].reward);
      e.env_return += results[i].reward;
      e.success = e.success || results[i].success;
      e.previous = e.current;
      e.current = standardizer.apply(results[i].observation).cast<float>();
      if (results[i].done()) {
        e.terminated = results[i].terminated;
        e.final_observation = e.current;
      } else {
        still.push_back(i);
      }
    }
    running = std::move(still);
  }

  Rollout rollout;
  std::int64_t total = 0;
  for (const auto& e : episodes) total += static_cast<std::int64_t>(e.rewards.size());
  rollout.observations.resize(total, S);
  rollout.previous_observations.resize(total, S);
  rollout.actions.resize(total, A);
  rollout.executed_actions.resize(total, A);
  rollout.log_probs.resize(total);
  rollout.env_rewards.resize(total);
  rollout.final_observations.resize(static_cast<Eigen::Index>(count), S);
  rollout.task_rows.assign(static_cast<std::size_t>(num_tasks), {});
  std::int64_t row = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const EpisodeBuffer& e = episodes[i];
    const auto length = static_cast<std::int64_t>(e.rewards.size());
    rollout.observations.middleRows(row, length) = Eigen::Map<const ag::RowMatrixF>(e.observations.data(), length, S);
    rollout.previous_observations.middleRows(row, length) =
        Eigen::Map<const ag::RowMatrixF>(e.previous_observations.data(), length, S);
    rollout.actions.middleRows(row, length) = Eigen::Map<const ag::RowMatrixF>(e.actions.data(), length, A);
    rollout.executed_actions.middleRows(row, length) = Eigen::Map<const ag::RowMatrixF>(e.executed.data(), length, A);
    rollout.log_probs.segment(row, length) = Eigen::Map<const Eigen::VectorXd>(e.log_probs.data(), length);
    rollout.env_rewards.segment(row, length) = Eigen::Map<const Eigen::VectorXd>(e.rewards.data(), length);
    rollout.final_observations.row(static_cast<Eigen::Index>(i)) = e.final_observation.transpose();
    for (std::int64_t t = 0; t < length; ++t) {
      rollout.tasks.push_back(env_tasks[i]);
      rollout.task_rows[static_cast<std::size_t>(env_tasks[i])].push_back(row + t);
    }
    rollout.episode_start.push_back(row);
    rollout.episode_length.push_back(length);
    rollout.episode_task.push_back(env_tasks[i]);
    rollout.episode_terminated.push_back(e.terminated);
    rollout.episode_success.push_back(e.success);
    rollout.episode_return.push_back(e.env_return);
    row += length;
  }
  return rollout;
}

}  // namespace maps::adversarial
