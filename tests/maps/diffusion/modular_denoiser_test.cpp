// maps::diffusion::ModularDenoiser, MAPS as a denoiser (issue 46, item 3): MAPS's mixture by hand (modules on [noisy
// chunk, step embedding, condition], selector on [state, task], head over the scored features), a selector that does
// not see the noisy chunk or the step, its selector losses on the batch's states, gradients in the inputs and every
// parameter (gradcheck, float64), and refusals by name.

#include "maps/diffusion/modular_denoiser.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "maps/diffusion/conditional_blocks.h"
#include "nn/mlp.h"
#include "tests/common/error_of.h"
#include "tests/common/max_abs_diff.h"
#include "tests/maps/diffusion/diffusion_test_util.h"

namespace {

namespace ag = maps::ag;
using diffusiontest::randn64;
using maps::diffusion::ModularDenoiser;
using maps::diffusion::ModularDenoiserConfig;
using ::testing::HasSubstr;

// S = 3, two states in the condition, K = 2 tasks: cond [s, s_prev, one_hot(k)] of 8.
ModularDenoiserConfig small_modular() {
  ModularDenoiserConfig c;
  c.horizon = 4;
  c.action_dim = 2;
  c.state_size = 3;
  c.cond_dim = 8;
  c.num_tasks = 2;
  c.modules = 3;
  c.module_hidden = {6, 5};
  c.selector_hidden = {4};
  c.step_embed_dim = 8;
  c.selector_losses = {{"share", 1.0}, {"explore", 0.5}, {"sparse", 0.001}, {"smooth", 1.0}};
  return c;
}

ag::Tensor condition(const ag::Tensor& states, const ag::Tensor& previous, const std::vector<std::int64_t>& tasks) {
  return ag::concat({states, previous, ag::one_hot(tasks, 2, ag::Dtype::Float64)}, 1);
}

TEST(ModularDenoiser, IsMAPSsMixtureByHand) {
  ag::Generator gen(1);
  ModularDenoiser net(small_modular(), gen);
  net.to(ag::Dtype::Float64);
  const ag::Tensor noisy = randn64({2, 4, 2}, 2), states = randn64({2, 3}, 3), previous = randn64({2, 3}, 4);
  const std::vector<std::int64_t> tasks{1, 0};
  const std::vector<int> steps{5, 80};
  const ag::Tensor cond = condition(states, previous, tasks);
  auto& embed = static_cast<maps::diffusion::StepEmbedding&>(*net.named_children()[0].module);
  const ag::Tensor x = ag::concat({ag::reshape(noisy, {2, 8}), embed.forward(steps), cond}, 1);
  const auto p = [&](const std::string& n) { return net.parameter(n); };
  const ag::Tensor g = net.scores(states, tasks);  // [2, 3]
  ag::Tensor expected = ag::reshape(p("head_bias"), {1, 8});
  for (std::int64_t m = 0; m < 3; ++m) {
    // Module m's [in, out] weight or [1, out] bias of a parallel layer ([M, in, out], [M, 1, out]).
    const auto slice = [&](const std::string& name) {
      const ag::Tensor all = p(name);
      return ag::reshape(ag::narrow(all, 0, m, 1), {all.size(1), all.size(2)});
    };
    ag::Tensor h = ag::tanh(ag::matmul(x, slice("modules0.weight")) + slice("modules0.bias"));
    h = ag::tanh(ag::matmul(h, slice("modules1.weight")) + slice("modules1.bias"));
    expected = expected + ag::matmul(h, slice("head.weight")) * ag::narrow(g, 1, m, 1);
  }
  EXPECT_LT(max_abs_diff(net.forward(noisy, steps, cond), ag::reshape(expected, {2, 4, 2})), 1e-12);
  // The scores are a softmax over modules of the selector on [s, one_hot(k)], whatever the noisy chunk and step.
  maps::nn::MLP* selector = nullptr;
  for (const auto& child : net.named_children())
    if (child.name == "selector") selector = static_cast<maps::nn::MLP*>(child.module.get());
  ASSERT_NE(selector, nullptr);
  const ag::Tensor logits = selector->forward(ag::concat({states, ag::one_hot(tasks, 2, ag::Dtype::Float64)}, 1));
  EXPECT_LT(max_abs_diff(g, ag::softmax(logits, 1)), 1e-12);
}

TEST(ModularDenoiser, SelectorLossesAreMAPSsOnTheStates) {
  ag::Generator gen(2);
  ModularDenoiser net(small_modular(), gen);
  net.to(ag::Dtype::Float64);
  const ag::Tensor states = randn64({4, 3}, 5), previous = randn64({4, 3}, 6);
  const std::vector<std::int64_t> tasks{0, 0, 1, 1};
  const maps::core::LossTerms terms = net.selector_terms(states, previous, tasks);
  ASSERT_EQ(terms.terms.size(), 4u);
  std::vector<std::string> names;
  double total = 0.0;
  const std::vector<double> weights{1.0, 0.5, 0.001, 1.0};
  for (std::size_t j = 0; j < 4; ++j) {
    names.push_back(terms.terms[j].first);
    total += weights[j] * terms.terms[j].second.item();
  }
  EXPECT_EQ(names, (std::vector<std::string>{"share", "explore", "sparse", "smooth"}));
  EXPECT_NEAR(terms.total.item(), total, 1e-12);
  // The smooth loss compares each state's scores with its previous state's: 0 when they are the same states.
  const maps::core::LossTerms same = net.selector_terms(states, states, tasks);
  EXPECT_NEAR(same.terms[3].second.item(), 0.0, 1e-15);
  ModularDenoiserConfig none = small_modular();
  none.selector_losses.clear();
  ModularDenoiser plain(none, gen);
  EXPECT_FALSE(
      plain.selector_terms(states.to(ag::Dtype::Float32), previous.to(ag::Dtype::Float32), tasks).total.defined());
}

TEST(ModularDenoiser, Gradcheck) {
  ag::Generator gen(4);
  ModularDenoiser net(small_modular(), gen);
  net.to(ag::Dtype::Float64);
  const ag::Tensor previous = randn64({2, 3}, 7);
  std::vector<ag::Tensor> inputs = {randn64({2, 4, 2}, 5).requires_grad_(), randn64({2, 3}, 6).requires_grad_()};
  for (const auto& t : net.parameters()) inputs.push_back(t);
  const auto r = ag::gradcheck(
      "ModularDenoiser",
      [&](const std::vector<ag::Tensor>& in) {
        const ag::Tensor out = net.forward(in[0], {1, 99}, condition(in[1], previous, {0, 1}));
        return ag::sum(out * out) + net.selector_terms(in[1], previous, {0, 1}).total;
      },
      inputs);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(ModularDenoiser, RefusesOtherShapesByName) {
  ag::Generator gen(7);
  ModularDenoiser net(small_modular(), gen);
  EXPECT_THAT(error_of([&] {
                net.forward(ag::zeros({2, 5, 2}), {0, 0}, ag::zeros({2, 8}));
              }),
              HasSubstr("expected noisy [batch, 4, 2], one step per row and cond [batch, 8], got [2, 5, 2]"));
  ModularDenoiserConfig bad = small_modular();
  bad.cond_dim = 4;  // cannot hold a state of 3 and two tasks
  EXPECT_THAT(error_of([&] { ModularDenoiser(bad, gen); }), HasSubstr("the condition must hold a state and the task"));
  bad = small_modular();
  bad.selector_losses = {{"share", -1.0}};
  EXPECT_THAT(error_of([&] { ModularDenoiser(bad, gen); }), HasSubstr("selector loss 'share' needs a finite weight"));
}

}  // namespace
