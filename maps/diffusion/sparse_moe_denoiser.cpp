#include "maps/diffusion/sparse_moe_denoiser.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

#include "maps/diffusion/conditional_blocks.h"
#include "maps/policies/policy.h"
#include "maps/policies/policy_registry.h"
#include "maps/policies/top_k_moe.h"
#include "nn/mlp.h"
#include "nn/module_list.h"
#include "nn/parallel_linear.h"

namespace maps::diffusion {
namespace {

constexpr double kGateFloor = 1e-4;  // SDP's TaskMoE adds it to every softmax gate

std::vector<std::int64_t> expert_sizes(const SparseMoeDenoiserConfig& c) {
  return flat_denoiser_layer_sizes(c.horizon, c.action_dim, c.step_embed_dim, c.cond_dim, c.hidden);
}

}  // namespace

SparseMoeDenoiser::SparseMoeDenoiser(const SparseMoeDenoiserConfig& config, ag::Generator& gen)
    : Denoiser("SparseMoeDenoiser"), config_(config) {
  if (config.horizon < 1 || config.action_dim < 1 || config.state_size < 1 || config.num_tasks < 1 ||
      config.hidden.empty() || config.router_hidden < 1 || config.cond_dim < config.state_size + config.num_tasks)
    throw std::invalid_argument(
        "SparseMoeDenoiser: horizon, action size, state size, tasks and router width must be "
        ">= 1, hidden not empty, and the condition must hold a state and the task");
  if (config.experts < 2 || config.top_k < 1 || config.top_k > config.experts)
    throw std::invalid_argument("SparseMoeDenoiser: expected experts >= 2 and 1 <= top_k <= experts, got " +
                                std::to_string(config.experts) + " and " + std::to_string(config.top_k));
  step_embedding_ = register_module("step_embedding", std::make_shared<StepEmbedding>(config.step_embed_dim, gen));
  auto experts = std::make_shared<nn::ModuleList>();
  for (std::int64_t i = 0; i < config.experts; ++i)
    experts->push_back(std::make_shared<nn::MLP>(expert_sizes(config), nn::Activation::Mish, gen));
  experts_ = register_module("experts", experts);
  router_first_ = register_module("router_first", std::make_shared<nn::ParallelLinear>(
                                                      config.num_tasks, config.state_size, config.router_hidden, gen));
  auto second = std::make_shared<nn::ParallelLinear>(config.num_tasks, config.router_hidden, config.experts, gen);
  second->weight().detach().copy_(ag::zeros(second->weight().shape()));  // SDP: the gate's last layer starts at 0
  second->bias().detach().copy_(ag::zeros(second->bias().shape()));
  router_second_ = register_module("router_second", second);
}

ag::Tensor SparseMoeDenoiser::probabilities(const ag::Tensor& states, const std::vector<std::int64_t>& tasks) {
  // Every task's router on every row ([K, n, E]), then each row's own task's: K small layers instead of K gathers.
  const ag::Tensor hidden = ag::mish(child_at<nn::ParallelLinear>(router_first_).forward(states));
  const ag::Tensor logits = child_at<nn::ParallelLinear>(router_second_).forward(hidden);
  const std::int64_t n = states.size(0);
  const ag::Tensor own =
      ag::index_select(ag::reshape(logits, {config_.num_tasks * n, config_.experts}), core::own_task_rows(tasks));
  return ag::softmax(own, 1);
}

ag::Tensor SparseMoeDenoiser::gates(const ag::Tensor& probabilities, std::vector<std::int64_t>* chosen) const {
  const std::int64_t n = probabilities.size(0), E = config_.experts, k = config_.top_k;
  const std::vector<double> values = probabilities.to_vector();
  std::vector<double> keep(static_cast<std::size_t>(n * E), 0.0);
  std::vector<std::int64_t> order(static_cast<std::size_t>(E));
  for (std::int64_t r = 0; r < n; ++r) {
    std::iota(order.begin(), order.end(), std::int64_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::int64_t a, std::int64_t b) {
      return values[static_cast<std::size_t>(r * E + a)] > values[static_cast<std::size_t>(r * E + b)];
    });
    for (std::int64_t j = 0; j < k; ++j) {
      keep[static_cast<std::size_t>(r * E + order[static_cast<std::size_t>(j)])] = 1.0;
      if (chosen != nullptr) chosen->push_back(order[static_cast<std::size_t>(j)]);
    }
  }
  return (probabilities + kGateFloor) * ag::from_vector(keep, {n, E}, probabilities.dtype());
}

ag::Tensor SparseMoeDenoiser::forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) {
  const std::int64_t n = noisy.size(0);
  const ag::Tensor x = flat_denoiser_input("SparseMoeDenoiser", noisy, steps, cond, config_.horizon, config_.action_dim,
                                           config_.cond_dim, child_at<StepEmbedding>(step_embedding_));
  // The task of each row from its one-hot, the condition's last K columns.
  const ag::RowMatrixD one_hot =
      ag::to_eigen_double(ag::narrow(cond, 1, config_.cond_dim - config_.num_tasks, config_.num_tasks));
  std::vector<std::int64_t> tasks(static_cast<std::size_t>(n));
  for (std::int64_t r = 0; r < n; ++r) {
    Eigen::Index task = 0;
    one_hot.row(r).maxCoeff(&task);
    tasks[static_cast<std::size_t>(r)] = task;
  }
  std::vector<std::int64_t> chosen;
  const ag::Tensor g = gates(probabilities(ag::narrow(cond, 1, 0, config_.state_size), tasks), &chosen);
  const ag::Tensor result = core::gated_expert_sum(child_at<nn::ModuleList>(experts_), x, chosen, g, config_.top_k);
  return ag::reshape(result, {n, config_.horizon, config_.action_dim});
}

ag::Tensor SparseMoeDenoiser::mutual_information(const ag::Tensor& probabilities,
                                                 const std::vector<std::int64_t>& tasks) const {
  const std::int64_t n = probabilities.size(0), K = config_.num_tasks;
  if (n == 0) throw std::invalid_argument("SparseMoeDenoiser::mutual_information: no rows");
  // P(k, e) = (1 / n) sum over task k's rows of p(e | row): a [K, n] averaging matrix times the probabilities.
  std::vector<double> weights(static_cast<std::size_t>(K * n), 0.0);
  for (std::int64_t r = 0; r < n; ++r)
    weights[static_cast<std::size_t>(tasks[static_cast<std::size_t>(r)] * n + r)] = 1.0 / n;
  const ag::Tensor joint =
      ag::matmul(ag::from_vector(weights, {K, n}, probabilities.dtype()), probabilities);  // [K, E]
  const ag::Tensor task_share = ag::sum(joint, {1}, true);                                 // [K, 1]
  const ag::Tensor expert_share = ag::sum(joint, {0}, true);                               // [1, E]
  // sum_{k,e} P(k, e) log(P(k, e) / (P(k) P(e))); tasks without rows and zero entries contribute 0 (a tiny floor
  // inside the log keeps 0 log 0 at 0 with a finite gradient).
  constexpr double kTiny = 1e-12;
  return ag::sum(joint * (ag::log(joint + kTiny) - ag::log(task_share * expert_share + kTiny)));
}

double sparse_moe_denoiser_parameter_count(const SparseMoeDenoiserConfig& c) {
  const double K = static_cast<double>(c.num_tasks), r = static_cast<double>(c.router_hidden),
               E = static_cast<double>(c.experts), S = static_cast<double>(c.state_size);
  return step_embedding_parameter_count(c.step_embed_dim) + E * core::mlp_parameter_count(expert_sizes(c)) +
         K * (S * r + r) + K * (r * E + E);
}

}  // namespace maps::diffusion
