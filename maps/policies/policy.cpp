#include "maps/policies/policy.h"

#include <algorithm>
#include <stdexcept>

namespace maps::core {

namespace {
// Rows per act() call: bounds the validation forward's memory (MAPS's [M, n, F] features).
constexpr std::int64_t kValidationChunk = 4096;
}  // namespace

std::vector<std::int64_t> own_task_rows(const std::vector<std::int64_t>& tasks) {
  const auto n = static_cast<std::int64_t>(tasks.size());
  std::vector<std::int64_t> rows(tasks.size());
  for (std::int64_t j = 0; j < n; ++j) rows[static_cast<std::size_t>(j)] = tasks[static_cast<std::size_t>(j)] * n + j;
  return rows;
}

void Policy::use_sampled_bc_loss() {
  if (sampled_bc_loss()) return;
  log_std_slot_ =
      static_cast<std::int64_t>(register_parameter("log_std", ag::zeros({shape_.action_size}, ag::Dtype::Float32)));
}

ag::Tensor Policy::bc_loss(const ag::Tensor& mean_actions, const Batch& batch) const {
  if (!sampled_bc_loss()) return ag::mse_loss(mean_actions, batch.actions);
  ag::Generator gen(batch.noise_seed);
  const ag::Tensor noise = ag::randn(mean_actions.shape(), gen, mean_actions.dtype());
  const ag::Tensor std = ag::exp(parameter_at(static_cast<std::size_t>(log_std_slot_)));
  return ag::mse_loss(mean_actions + std * noise, batch.actions);
}

PolicyForward Policy::forward_terms(const Batch& batch) { return {act(batch.observations, batch.tasks), {}}; }

ag::Tensor Policy::act_with_history(const ag::Tensor& observations, const ag::Tensor& /*previous_observations*/,
                                    const std::vector<std::int64_t>& tasks) {
  return act(observations, tasks);
}

void Policy::set_chunking(const chunking::ActionChunking& chunking, std::int64_t action_size) {
  chunking::check_action_chunking(chunking, "chunking");
  if (action_size < 1 || chunking.horizon * action_size != shape_.action_size)
    throw std::invalid_argument(type_name() + ": chunks of " + std::to_string(chunking.horizon) + " actions of size " +
                                std::to_string(action_size) + " need an output of " +
                                std::to_string(chunking.horizon * action_size) + ", the policy was built for " +
                                std::to_string(shape_.action_size));
  chunking_ = chunking;
}

double Policy::validation_loss(const Batch& validation, const DemoDataset& /*data*/) {
  return mean_action_error(*this, validation);
}

double mean_action_error(Policy& policy, const Batch& batch) {
  ag::NoGradGuard no_grad;
  const std::int64_t n = batch.size();
  if (n == 0) throw std::invalid_argument("mean_action_error: empty batch");
  double total = 0.0;
  for (std::int64_t start = 0; start < n; start += kValidationChunk) {
    const std::int64_t count = std::min(kValidationChunk, n - start);
    const std::vector<std::int64_t> tasks(batch.tasks.begin() + start, batch.tasks.begin() + start + count);
    const ag::Tensor prediction = policy.act(ag::narrow(batch.observations, 0, start, count), tasks);
    total += ag::mse_loss(prediction, ag::narrow(batch.actions, 0, start, count)).item() * static_cast<double>(count);
  }
  return total / static_cast<double>(n);
}

}  // namespace maps::core
