#pragma once

// A sparse top-k mixture-of-experts denoiser after Sparse Diffusion Policy (Wang et al., CoRL 2024; issue 46, item 3):
// E expert denoisers (MLPs on the flattened noisy chunk, the step's embedding and the condition), a router per task
// on the current state (S -> r -> Mish -> E, its last layer starting at 0), gates softmax(logits) + 1e-4 of which
// each row keeps its top k, not renormalised (SDP's TaskMoE), only the chosen experts running on a row, and SDP's
// task-expert mutual-information loss. Departures (docs/zoo.md): the router reads the state, not the noisy tokens,
// so a state and task route the same way at every denoising step, as MAPS's selector does; the mutual information
// is estimated on each balanced batch, not from an EMA, and is on from the first step.

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/diffusion/denoiser.h"

namespace maps::diffusion {

struct SparseMoeDenoiserConfig {
  std::int64_t horizon = 0;
  std::int64_t action_dim = 0;
  std::int64_t state_size = 0;  // S: the condition starts with the current state
  std::int64_t cond_dim = 0;
  std::int64_t num_tasks = 0;  // K: one router each
  std::int64_t experts = 8;
  std::int64_t top_k = 2;
  std::vector<std::int64_t> hidden{128, 128};  // each expert's hidden layers (Mish)
  std::int64_t router_hidden = 32;
  std::int64_t step_embed_dim = 32;
};

class SparseMoeDenoiser : public Denoiser {
 public:
  SparseMoeDenoiser(const SparseMoeDenoiserConfig& config, ag::Generator& gen);

  ag::Tensor forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) override;
  // Each row's router probabilities softmax(logits) [n, E] (dense, before the top k) for states [n, S] of tasks.
  ag::Tensor probabilities(const ag::Tensor& states, const std::vector<std::int64_t>& tasks);
  // The gates a row uses: its top k of probabilities + 1e-4, the others 0 [n, E]; `chosen` gets the experts, k per
  // row, best first (ties to the lower index).
  ag::Tensor gates(const ag::Tensor& probabilities, std::vector<std::int64_t>* chosen) const;
  // The mutual information I(task; expert) of the batch: P(e | k) the mean of the rows' probabilities over task k's
  // rows, P(k) the share of its rows, P(e) = sum_k P(k) P(e | k). Needs at least one row.
  ag::Tensor mutual_information(const ag::Tensor& probabilities, const std::vector<std::int64_t>& tasks) const;
  const SparseMoeDenoiserConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<SparseMoeDenoiser>(*this); }

 private:
  SparseMoeDenoiserConfig config_;
  std::size_t step_embedding_ = 0;
  std::size_t experts_ = 0;
  std::size_t router_first_ = 0, router_second_ = 0;  // ParallelLinear over the K tasks' routers
};

double sparse_moe_denoiser_parameter_count(const SparseMoeDenoiserConfig& config);

}  // namespace maps::diffusion
