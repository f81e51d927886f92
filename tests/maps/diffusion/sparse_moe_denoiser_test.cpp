// maps::diffusion::SparseMoeDenoiser, top-k experts after Sparse Diffusion Policy (issue 46, item 3): gates are each
// row's top k of its task's router softmax plus 1e-4 (not renormalised), the estimate is the chosen experts' gated
// sum by hand, the router starts uniform (its last layer at 0), the task-expert mutual information by hand, gradients
// in the inputs and every parameter (gradcheck, float64, away from ties), and refusals by name.

#include "maps/diffusion/sparse_moe_denoiser.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "maps/diffusion/conditional_blocks.h"
#include "nn/mlp.h"
#include "nn/module_list.h"
#include "tests/common/error_of.h"
#include "tests/common/max_abs_diff.h"
#include "tests/maps/diffusion/diffusion_test_util.h"

namespace {

namespace ag = maps::ag;
using diffusiontest::randn64;
using maps::diffusion::SparseMoeDenoiser;
using maps::diffusion::SparseMoeDenoiserConfig;
using ::testing::HasSubstr;

// S = 3, cond [s, one_hot(k)] of 5 with K = 2; 4 experts, top 2.
SparseMoeDenoiserConfig small_moe() {
  SparseMoeDenoiserConfig c;
  c.horizon = 4;
  c.action_dim = 2;
  c.state_size = 3;
  c.cond_dim = 5;
  c.num_tasks = 2;
  c.experts = 4;
  c.top_k = 2;
  c.hidden = {6};
  c.router_hidden = 5;
  c.step_embed_dim = 8;
  return c;
}

ag::Tensor condition(const ag::Tensor& states, const std::vector<std::int64_t>& tasks) {
  return ag::concat({states, ag::one_hot(tasks, 2, ag::Dtype::Float64)}, 1);
}

// The router's last layer moved off 0, so that rows choose different experts and no two probabilities tie.
void spread_router(SparseMoeDenoiser& net, std::uint64_t seed) {
  for (const auto& [name, tensor] : net.named_parameters())
    if (name.rfind("router_second", 0) == 0) tensor.detach().copy_(randn64(tensor.shape(), seed++));
}

TEST(SparseMoeDenoiser, TheRouterStartsUniformAndRowsKeepTheirTopK) {
  ag::Generator gen(1);
  SparseMoeDenoiser net(small_moe(), gen);
  net.to(ag::Dtype::Float64);
  const ag::Tensor states = randn64({3, 3}, 2);
  const std::vector<std::int64_t> tasks{0, 1, 1};
  const ag::Tensor p = net.probabilities(states, tasks);
  for (double v : p.to_vector()) EXPECT_NEAR(v, 0.25, 1e-15);
  std::vector<std::int64_t> chosen;
  const auto g = net.gates(p, &chosen).to_vector();
  EXPECT_EQ(chosen, (std::vector<std::int64_t>{0, 1, 0, 1, 0, 1}));  // ties to the lower index
  for (std::int64_t r = 0; r < 3; ++r)
    for (std::int64_t e = 0; e < 4; ++e)
      EXPECT_NEAR(g[static_cast<std::size_t>(4 * r + e)], e < 2 ? 0.2501 : 0.0, 1e-15);
}

TEST(SparseMoeDenoiser, IsTheChosenExpertsGatedSumByHand) {
  ag::Generator gen(3);
  SparseMoeDenoiser net(small_moe(), gen);
  net.to(ag::Dtype::Float64);
  spread_router(net, 4);
  const ag::Tensor noisy = randn64({5, 4, 2}, 5), states = randn64({5, 3}, 6);
  const std::vector<std::int64_t> tasks{0, 1, 0, 1, 1};
  const std::vector<int> steps{0, 10, 20, 30, 99};
  const ag::Tensor cond = condition(states, tasks);
  auto& embed = static_cast<maps::diffusion::StepEmbedding&>(*net.named_children()[0].module);
  auto& experts = static_cast<maps::nn::ModuleList&>(*net.named_children()[1].module);
  const ag::Tensor x = ag::concat({ag::reshape(noisy, {5, 8}), embed.forward(steps), cond}, 1);
  const ag::Tensor g = net.gates(net.probabilities(states, tasks), nullptr);
  // Dense by hand: every expert on every row, weighted by the gate (0 for the experts a row did not keep).
  ag::Tensor expected = ag::zeros({5, 8}, ag::Dtype::Float64);
  for (std::size_t e = 0; e < 4; ++e)
    expected = expected + experts.at<maps::nn::MLP>(e).forward(x) * ag::narrow(g, 1, static_cast<std::int64_t>(e), 1);
  EXPECT_LT(max_abs_diff(net.forward(noisy, steps, cond), ag::reshape(expected, {5, 4, 2})), 1e-12);
  // Rows differ in the experts they keep (the router is spread).
  std::vector<std::int64_t> chosen;
  net.gates(net.probabilities(states, tasks), &chosen);
  EXPECT_GT(std::set<std::int64_t>(chosen.begin(), chosen.end()).size(), 2u);
}

TEST(SparseMoeDenoiser, MutualInformationByHand) {
  ag::Generator gen(7);
  SparseMoeDenoiser net(small_moe(), gen);
  // Task 0's rows all on expert 0, task 1's on expert 1: I = H(expert) = log 2 (tasks equally many).
  const ag::Tensor split =
      ag::from_vector({1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0}, {4, 4}, ag::Dtype::Float64);
  EXPECT_NEAR(net.mutual_information(split, {0, 0, 1, 1}).item(), std::log(2.0), 1e-9);
  // Every row the same distribution: the expert says nothing of the task.
  const ag::Tensor same = ag::full({4, 4}, 0.25, ag::Dtype::Float64);
  EXPECT_NEAR(net.mutual_information(same, {0, 0, 1, 1}).item(), 0.0, 1e-9);
  // Three rows of task 0 half on experts 0 and 1, one of task 1 on expert 2: P(k) = (3/4, 1/4), P(e) = (3/8, 3/8,
  // 1/4, 0): I = 3/4 (2 x 1/2 log((1/2) / (3/8))) + 1/4 log(1 / (1/4)).
  const ag::Tensor mixed =
      ag::from_vector({.5, .5, 0, 0, .5, .5, 0, 0, .5, .5, 0, 0, 0, 0, 1, 0}, {4, 4}, ag::Dtype::Float64);
  const double expected = 0.75 * std::log(0.5 / 0.375) + 0.25 * std::log(4.0);
  EXPECT_NEAR(net.mutual_information(mixed, {0, 0, 0, 1}).item(), expected, 1e-9);
}

TEST(SparseMoeDenoiser, Gradcheck) {
  ag::Generator gen(4);
  SparseMoeDenoiser net(small_moe(), gen);
  net.to(ag::Dtype::Float64);
  spread_router(net, 11);
  const std::vector<std::int64_t> tasks{0, 1, 1};
  std::vector<ag::Tensor> inputs = {randn64({3, 4, 2}, 5).requires_grad_(), randn64({3, 3}, 6).requires_grad_()};
  for (const auto& t : net.parameters()) inputs.push_back(t);
  const auto r = ag::gradcheck(
      "SparseMoeDenoiser",
      [&](const std::vector<ag::Tensor>& in) {
        const ag::Tensor out = net.forward(in[0], {1, 50, 99}, condition(in[1], tasks));
        return ag::sum(out * out) + net.mutual_information(net.probabilities(in[1], tasks), tasks);
      },
      inputs);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(SparseMoeDenoiser, RefusesOtherShapesByName) {
  ag::Generator gen(7);
  SparseMoeDenoiser net(small_moe(), gen);
  EXPECT_THAT(error_of([&] {
                net.forward(ag::zeros({2, 5, 2}), {0, 0}, ag::zeros({2, 5}));
              }),
              HasSubstr("expected noisy [batch, 4, 2], one step per row and cond [batch, 5], got [2, 5, 2]"));
  SparseMoeDenoiserConfig bad = small_moe();
  bad.top_k = 5;
  EXPECT_THAT(error_of([&] { SparseMoeDenoiser(bad, gen); }), HasSubstr("1 <= top_k <= experts, got 4 and 5"));
  EXPECT_THAT(error_of([&] { net.mutual_information(ag::zeros({0, 4}), {}); }), HasSubstr("no rows"));
}

}  // namespace
