#include "maps/policies/maps_flops.h"

#include <stdexcept>
#include <vector>

namespace maps::core {

double maps_training_step_flops(const PolicyShape& shape, const MAPSConfig& config, std::int64_t per_task) {
  if (per_task < 1) throw std::invalid_argument("maps_training_step_flops: per_task must be >= 1");
  const double S = static_cast<double>(shape.observation_size), A = static_cast<double>(shape.action_size);
  const double K = static_cast<double>(shape.num_tasks), M = static_cast<double>(config.modules);
  const double n = K * static_cast<double>(per_task);

  double flops = 0.0;
  double in = S;
  for (std::size_t i = 0; i < config.module_hidden.size(); ++i) {
    const double layer = 2.0 * n * M * in * static_cast<double>(config.module_hidden[i]);
    flops += layer * (i == 0 ? 2.0 : 3.0);  // forward, weight gradient, input gradient but for the first
    in = static_cast<double>(config.module_hidden[i]);
  }
  flops += 3.0 * 2.0 * n * M * in * A;  // head

  std::vector<double> sizes(config.selector_hidden.begin(), config.selector_hidden.end());
  sizes.push_back(M);
  const double rows = (K + 1.0) * n;
  flops += 2.0 * (2.0 * 2.0 * n * S * sizes[0]);  // first layer's state part: forward and weight gradient on 2n rows
  for (std::size_t i = 1; i < sizes.size(); ++i) flops += 3.0 * 2.0 * rows * sizes[i - 1] * sizes[i];
  return flops;
}

}  // namespace maps::core
