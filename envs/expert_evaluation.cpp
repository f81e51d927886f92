#include "envs/expert_evaluation.h"

#include <cmath>

namespace maps::envs {

double ExpertEpisodes::mean_return() const {
  double total = 0.0;
  for (double r : returns) total += r;
  return returns.empty() ? 0.0 : total / static_cast<double>(returns.size());
}

double ExpertEpisodes::mean_return_unclipped_cost() const {
  double total = 0.0;
  for (double r : returns_unclipped_cost) total += r;
  return returns_unclipped_cost.empty() ? 0.0 : total / static_cast<double>(returns_unclipped_cost.size());
}

double ExpertEpisodes::return_std() const {
  const double mean = mean_return();
  double total = 0.0;
  for (double r : returns) total += (r - mean) * (r - mean);
  return returns.empty() ? 0.0 : std::sqrt(total / static_cast<double>(returns.size()));
}

int ExpertEpisodes::success_count() const {
  int count = 0;
  for (bool s : successes) count += s ? 1 : 0;
  return count;
}

int ExpertEpisodes::failed_count() const {
  int count = 0;
  for (double f : failure_fractions) count += f > 0.5 ? 1 : 0;
  return count;
}

ExpertEpisodes run_expert(Env& env, const TaskExpert& expert, int episodes, std::uint64_t first_seed) {
  ExpertEpisodes out;
  for (int e = 0; e < episodes; ++e) {
    Eigen::VectorXd obs = env.reset(first_seed + static_cast<std::uint64_t>(e));
    double total = 0.0, unclipped_cost = 0.0;
    int steps = 0, failure_steps = 0, first_success = -1;
    for (bool done = false; !done; ++steps) {
      const StepResult r = env.step(expert.mean_action(obs));
      total += r.reward;
      unclipped_cost += r.unclipped_control_cost;
      if (r.success && first_success < 0) first_success = steps;
      failure_steps += env.in_failure_state() ? 1 : 0;
      obs = r.observation;
      done = r.done();
    }
    out.returns.push_back(total);
    out.returns_unclipped_cost.push_back(total - unclipped_cost);
    out.successes.push_back(first_success >= 0);
    out.first_success_steps.push_back(first_success);
    out.failure_fractions.push_back(static_cast<double>(failure_steps) / steps);
  }
  return out;
}

}  // namespace maps::envs
