#include "maps/rl/gae.h"

#include <stdexcept>
#include <string>

namespace maps::rl {

GaeResult compute_gae(const Eigen::VectorXd& rewards, const Eigen::VectorXd& values, const Eigen::VectorXd& next_values,
                      const std::vector<bool>& terminated, const std::vector<bool>& episode_end, double gamma,
                      double lambda) {
  const Eigen::Index n = rewards.size();
  if (values.size() != n || next_values.size() != n || static_cast<Eigen::Index>(terminated.size()) != n ||
      static_cast<Eigen::Index>(episode_end.size()) != n)
    throw std::invalid_argument("compute_gae: rewards, values, next_values, terminated and episode_end must have " +
                                std::to_string(n) + " entries each");
  GaeResult out;
  out.advantages.resize(n);
  double next_advantage = 0.0;
  for (Eigen::Index t = n - 1; t >= 0; --t) {
    const auto i = static_cast<std::size_t>(t);
    if (terminated[i] && !episode_end[i])
      throw std::invalid_argument("compute_gae: step " + std::to_string(t) + " is terminated but not an episode end");
    const double bootstrap = terminated[i] ? 0.0 : gamma * next_values(t);
    const double delta = rewards(t) + bootstrap - values(t);
    const double carry = episode_end[i] ? 0.0 : gamma * lambda * next_advantage;
    out.advantages(t) = delta + carry;
    next_advantage = out.advantages(t);
  }
  out.returns = out.advantages + values;
  return out;
}

}  // namespace maps::rl
