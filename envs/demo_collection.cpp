#include "envs/demo_collection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "envs/portable_random.h"

namespace maps::envs {
namespace {

struct Episode {
  Demonstration demo;
  double failure_fraction = 0.0;
  bool ended_in_failure = false;
};

Episode roll_out(Env& env, const TaskExpert& expert, std::uint64_t seed, const DemoCollectionConfig& config) {
  const EnvSpec& spec = env.spec();
  std::mt19937_64 noise(splitmix64(seed ^ splitmix64(config.noise_seed)));
  std::vector<Eigen::VectorXd> observations, actions;
  std::vector<double> rewards;
  Episode episode;
  Eigen::VectorXd obs = env.reset(seed);
  int failure_steps = 0;
  for (bool done = false; !done;) {
    Eigen::VectorXd action =
        config.actions == DemoActions::kMean ? expert.mean_action(obs) : expert.sample_action(obs, noise);
    if (action.size() != spec.action_size || !action.allFinite()) {
      throw std::runtime_error("demonstrations of " + spec.task + ": the expert (" + expert.source + ") gave " +
                               std::to_string(action.size()) + " action entries" +
                               (action.allFinite() ? "" : " with a NaN or infinity") + ", the env takes " +
                               std::to_string(spec.action_size));
    }
    // Store what the env applies: it clips to its bounds, and a learner should imitate the applied action.
    action = action.cwiseMax(spec.action_low).cwiseMin(spec.action_high);
    const StepResult result = env.step(action);
    observations.push_back(obs);
    actions.push_back(action);
    rewards.push_back(result.reward);
    episode.demo.success = episode.demo.success || result.success;
    if (env.in_failure_state()) ++failure_steps;
    done = result.done();
    if (done) {
      episode.ended_in_failure = env.in_failure_state();
      episode.demo.end = result.terminated ? EpisodeEnd::kTerminated : EpisodeEnd::kTruncated;
    }
    obs = result.observation;
  }
  const int steps = static_cast<int>(rewards.size());
  Demonstration& demo = episode.demo;
  demo.task = spec.task;
  demo.task_index = spec.task_index;
  demo.seed = seed;
  demo.obs.resize(steps, spec.observation_size);
  demo.actions.resize(steps, spec.action_size);
  demo.rewards.resize(steps);
  demo.dones.assign(steps, 0);
  demo.dones.back() = 1;
  for (int t = 0; t < steps; ++t) {
    demo.obs.row(t) = observations[t].transpose();
    demo.actions.row(t) = actions[t].transpose();
    demo.rewards[t] = rewards[t];
  }
  demo.final_obs = obs;
  demo.episode_return = demo.rewards.sum();
  episode.failure_fraction = static_cast<double>(failure_steps) / steps;
  return episode;
}

template <typename... Numbers>
std::string format(const char* pattern, Numbers... numbers) {
  char text[160];
  std::snprintf(text, sizeof text, pattern, numbers...);
  return text;
}

void check_config(const Env& env, const TaskExpert& expert, const DemoCollectionConfig& config) {
  const std::string task = env.spec().task;
  if (config.demos < 1) {
    throw std::invalid_argument("demonstrations of " + task + ": demos must be >= 1, got " +
                                std::to_string(config.demos));
  }
  if (config.max_attempts_factor < 1) {
    throw std::invalid_argument("demonstrations of " + task + ": max_attempts_factor must be >= 1, got " +
                                std::to_string(config.max_attempts_factor));
  }
  if (!(config.min_return_fraction >= 0.0 && config.min_return_fraction <= 1.0) ||
      !(config.max_failure_fraction >= 0.0 && config.max_failure_fraction <= 1.0)) {
    throw std::invalid_argument("demonstrations of " + task +
                                ": min_return_fraction and max_failure_fraction must be in [0, 1]");
  }
  if (expert.task != task) {
    throw std::invalid_argument("demonstrations of " + task + ": the expert was trained on '" + expert.task + "'");
  }
  if (!expert.mean_action || !expert.sample_action) {
    throw std::invalid_argument("demonstrations of " + task + ": the expert has no policy");
  }
}

}  // namespace

std::string to_string(DemoActions actions) { return actions == DemoActions::kMean ? "mean" : "sample"; }

DemoActions parse_demo_actions(const std::string& word) {
  if (word == "mean") return DemoActions::kMean;
  if (word == "sample") return DemoActions::kSample;
  throw std::invalid_argument("demonstration actions: expected 'mean' or 'sample', got '" + word + "'");
}

TaskDemonstrations collect_task_demonstrations(Env& env, const TaskExpert& expert, const DemoCollectionConfig& config) {
  check_config(env, expert, config);
  const std::string task = env.spec().task;
  const std::uint64_t max_attempts = static_cast<std::uint64_t>(config.demos) * config.max_attempts_factor;
  if (config.first_seed > kEvalSeedBegin || kEvalSeedBegin - config.first_seed < max_attempts) {
    throw std::invalid_argument("demonstrations of " + task + ": seeds from " + std::to_string(config.first_seed) +
                                " could reach the evaluation range (" + std::to_string(kEvalSeedBegin) + " and up)");
  }

  std::vector<Episode> first;
  for (int i = 0; i < config.demos; ++i) first.push_back(roll_out(env, expert, config.first_seed + i, config));
  std::vector<double> returns;
  for (const Episode& e : first) returns.push_back(e.demo.episode_return);
  std::nth_element(returns.begin(), returns.begin() + returns.size() / 2, returns.end());
  TaskDemonstrations result;
  result.median_return = returns[returns.size() / 2];
  if (returns.size() % 2 == 0) {
    result.median_return =
        0.5 * (result.median_return + *std::max_element(returns.begin(), returns.begin() + returns.size() / 2));
  }
  const double min_return = config.min_return_fraction * result.median_return;

  const auto keep_or_discard = [&](Episode&& episode) {
    std::string reason;
    if (config.require_success && !episode.demo.success) {
      reason = "never met the success test";
    } else if (episode.ended_in_failure) {
      reason = "ended in the failure state (turned over)";
    } else if (episode.failure_fraction > config.max_failure_fraction) {
      reason = format("%.1f%% of its steps in the failure state (turned over), more than %.1f%%",
                      100.0 * episode.failure_fraction, 100.0 * config.max_failure_fraction);
    } else if (episode.demo.episode_return < min_return) {
      reason = format("return %.1f < %.2f x median %.1f", episode.demo.episode_return, config.min_return_fraction,
                      result.median_return);
    }
    if (reason.empty()) {
      result.demos.push_back(std::move(episode.demo));
    } else {
      result.discarded.push_back({episode.demo.seed, episode.demo.episode_return, reason});
    }
  };
  for (Episode& e : first) keep_or_discard(std::move(e));
  std::uint64_t seed = config.first_seed + config.demos;
  while (static_cast<int>(result.demos.size()) < config.demos) {
    if (seed - config.first_seed >= max_attempts) {
      std::string message = "demonstrations of " + task + ": only " + std::to_string(result.demos.size()) + " of " +
                            std::to_string(max_attempts) + " episodes passed the quality test (median return " +
                            format("%.1f", result.median_return) + "); first reasons:";
      for (std::size_t i = 0; i < std::min<std::size_t>(3, result.discarded.size()); ++i)
        message += " seed " + std::to_string(result.discarded[i].seed) + ": " + result.discarded[i].reason + ";";
      throw std::runtime_error(message);
    }
    keep_or_discard(roll_out(env, expert, seed++, config));
  }
  return result;
}

}  // namespace maps::envs
