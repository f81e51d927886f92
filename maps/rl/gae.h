#pragma once

#include <Eigen/Core>
#include <vector>

namespace maps::rl {

struct GaeResult {
  Eigen::VectorXd advantages;
  Eigen::VectorXd returns;  // advantages + values: the value targets
};

// Generalised advantage estimation over one rollout of T steps (one env), with the time limit handled by
// bootstrapping, which is what SB3 does by adding gamma V(final obs) to the reward of a truncated step:
//   delta_t = r_t + gamma (1 - terminated_t) next_values_t - values_t
//   A_t     = delta_t + gamma lambda (1 - episode_end_t) A_{t+1}      (A_T = 0)
// values_t = V(s_t); next_values_t = V(s_{t+1}) where s_{t+1} is the observation step t returned (for a truncated
// step, the final observation of the episode, not the next episode's first; for the rollout's last step, the
// observation the next rollout starts from). terminated_t: a real terminal (no bootstrap). episode_end_t:
// terminated or truncated (the recursion stops there).
GaeResult compute_gae(const Eigen::VectorXd& rewards, const Eigen::VectorXd& values, const Eigen::VectorXd& next_values,
                      const std::vector<bool>& terminated, const std::vector<bool>& episode_end, double gamma,
                      double lambda);

}  // namespace maps::rl
