// The zoo's modular methods (docs/zoo.md), each through the registry as `maps train` builds it: its parameter count
// as the registry estimates it, the width matched to MAPS's, learning a small four-task problem, the same actions on
// balanced and mixed batches, and routing shares that are a distribution over its modules.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "maps/policies/care.h"
#include "maps/policies/moore.h"
#include "maps/policies/paco.h"
#include "maps/policies/policy_registry.h"
#include "maps/policies/soft_modularization.h"
#include "maps/policies/top_k_moe.h"
#include "maps/training/run_config.h"
#include "tests/maps/policies/baseline_test_util.h"

namespace {

namespace ag = maps::ag;
namespace core = maps::core;
using baselinetest::make_batch;
using baselinetest::rows_of;
using baselinetest::shuffled_rows;
using baselinetest::train;
using ::testing::HasSubstr;

const core::PolicyShape kShape{3, 2, 4};

struct ZooCase {
  std::string method;
  nlohmann::json small;  // the method's own section at test size
  // Keys that make its training loss independent of the rows' order (top-k's noise is drawn per row position).
  nlohmann::json without_noise = nlohmann::json::object();
};

// The methods added after the paper, each at a size that trains in a second.
const std::vector<ZooCase> kZoo = {
    {"moore", {{"experts", 3}, {"layers", 2}, {"width", 32}}},
    {"paco", {{"parameter_sets", 3}, {"layers", 2}, {"width", 32}}},
    {"care", {{"encoders", 3}, {"encoder_width", 16}, {"context_width", 16}, {"layers", 2}, {"width", 32}}},
    {"care",
     {{"encoders", 3},
      {"encoder_width", 16},
      {"context_width", 16},
      {"layers", 2},
      {"width", 32},
      {"attention", "task"}}},
    {"top_k_moe", {{"experts", 4}, {"top_k", 2}, {"layers", 2}, {"width", 32}}, {{"noise", false}}},
    {"soft_modularization",
     {{"module_layers", 3}, {"modules", 3}, {"module_width", 16}, {"base_width", 16}, {"gating_width", 16}}},
    {"soft_modularization",
     {{"module_layers", 2},
      {"modules", 2},
      {"module_width", 16},
      {"base_width", 16},
      {"gating_width", 16},
      {"aggregation", "sum"}}},
};

core::RunConfig config_of(const std::string& method, const nlohmann::json& own, std::uint64_t seed = 0) {
  nlohmann::json json{{"method", method}, {"seed", seed}, {"data", {{"file", "unused.h5"}}}};
  if (!own.is_null()) json[method] = own;
  return core::parse_run_config(json);
}

TEST(Zoo, EveryMethodIsRegisteredWithASummaryAndItsOwnSection) {
  for (const auto& c : kZoo) {
    const auto& entry = core::policy_method(c.method);
    EXPECT_FALSE(entry.summary.empty()) << c.method;
    EXPECT_FALSE(entry.defaults.empty()) << c.method;
    EXPECT_EQ(core::to_json(config_of(c.method, c.small))[c.method].size(), entry.defaults.size()) << c.method;
  }
}

TEST(Zoo, ParameterCountIsTheRegistrysEstimate) {
  for (const auto& c : kZoo) {
    const auto config = config_of(c.method, c.small);
    const auto policy = core::make_policy(config, kShape);
    EXPECT_EQ(static_cast<double>(policy->parameter_count()), core::policy_parameter_count(config, kShape)) << c.method;
  }
}

// The default width (0) gives the paper's shape at MAPS's parameter count under the same config (within one width
// step), on each set's shapes.
TEST(Zoo, DefaultWidthMatchesMAPSsParameterCount) {
  for (const core::PolicyShape shape :
       {core::PolicyShape{17, 6, 5}, core::PolicyShape{17, 6, 11}, core::PolicyShape{39, 4, 10}}) {
    for (const auto& c : kZoo) {
      const auto config = config_of(c.method, nlohmann::json::object());
      const double maps_count = core::maps_parameter_count(config, shape);
      const double count = static_cast<double>(core::make_policy(config, shape)->parameter_count());
      EXPECT_NEAR(count / maps_count, 1.0, 0.03) << c.method << " S " << shape.observation_size << " K "
                                                 << shape.num_tasks << ": " << count << " vs MAPS " << maps_count;
    }
  }
}

TEST(Zoo, MAPSCountIsMAPSsOwn) {
  for (const core::PolicyShape shape : {core::PolicyShape{17, 6, 5}, core::PolicyShape{39, 4, 10}}) {
    const auto config = config_of("maps", nullptr);
    EXPECT_EQ(static_cast<double>(core::make_policy(config, shape)->parameter_count()),
              core::maps_parameter_count(config, shape));
  }
}

// Four tasks with different smooth targets, 32 states each: each method fits them in 600 Adam steps, from about 0.4
// to below 3e-3 (measured at these seeds: moore 7.3e-6, paco 9.2e-5, care 7.3e-5 "dot" and 1.1e-4 "task", top_k_moe
// 1.5e-5 (its total, with the balancing terms), soft_modularization 2.6e-4 "softmax" and 3.8e-4 "sum"; the bound
// leaves a factor of 7 or more).
TEST(Zoo, EachLearnsASmallFourTaskProblem) {
  for (const auto& c : kZoo) {
    const auto policy = core::make_policy(config_of(c.method, c.small, 3), kShape);
    const auto losses = train(*policy, make_batch(4, 32, 4), 600, 3e-3);
    EXPECT_LT(losses.back(), 3e-3) << c.method << ": " << losses.front() << " -> " << losses.back();
  }
}

TEST(Zoo, MixedRowsActAsInTheBalancedBatch) {
  for (const auto& c : kZoo) {
    nlohmann::json own = c.small;
    own.update(c.without_noise);
    const auto policy = core::make_policy(config_of(c.method, own, 5), kShape);
    const core::Batch batch = make_batch(4, 8, 6);
    const auto rows = shuffled_rows(32, 7);
    const core::Batch mixed = rows_of(batch, rows);
    const ag::Tensor balanced = ag::index_select(policy->act(batch.observations, batch.tasks), rows);
    EXPECT_LT(max_abs_diff(policy->act(mixed.observations, mixed.tasks), balanced), 1e-6) << c.method;
    // The loss of a balanced batch equals that of its rows in another order (the balanced path is a shortcut).
    EXPECT_NEAR(policy->loss(batch).total.item(), policy->loss(mixed).total.item(), 1e-6) << c.method;
  }
}

TEST(Zoo, RoutingIsADistributionOverTheModules) {
  for (const auto& c : kZoo) {
    const auto policy = core::make_policy(config_of(c.method, c.small, 8), kShape);
    const core::Batch batch = make_batch(4, 5, 9);
    const ag::Tensor routing = policy->routing(batch.observations, batch.tasks);
    ASSERT_TRUE(routing.defined()) << c.method;
    ASSERT_EQ(routing.shape(), (ag::Shape{20, policy->routed_modules()})) << c.method;
    const auto values = routing.to_vector();
    for (std::int64_t r = 0; r < 20; ++r) {
      double total = 0.0;
      for (std::int64_t m = 0; m < policy->routed_modules(); ++m) {
        const double v = values[static_cast<std::size_t>(r * policy->routed_modules() + m)];
        EXPECT_GE(v, 0.0) << c.method;
        total += v;
      }
      EXPECT_NEAR(total, 1.0, 1e-5) << c.method << " row " << r;
    }
  }
}

TEST(Zoo, OwnSectionsAreCheckedByNameAndType) {
  EXPECT_THAT(error_of([] { config_of("moore", {{"expert", 3}}); }), HasSubstr("config moore: unknown key 'expert'"));
  EXPECT_THAT(error_of([] {
                config_of("moore", {{"experts", 2.5}});
              }),
              HasSubstr("config moore.experts: wrong type (2.5), expected an integer"));
  EXPECT_THAT(error_of([] { config_of("moore", {{"experts", 0}}); }), HasSubstr("config moore.experts: expected 1"));
  EXPECT_THAT(error_of([] {
                config_of("moore", {{"orthogonal", 1}});
              }),
              HasSubstr("config moore.orthogonal: wrong type (1), expected true or false"));
  // Another method's section is checked too, and kept out of this run's resolved config.
  EXPECT_THAT(error_of([] {
                core::parse_run_config({{"method", "maps"}, {"data", {{"file", "x.h5"}}}, {"moore", {{"widht", 3}}}});
              }),
              HasSubstr("config moore: unknown key 'widht'"));
  const auto maps_config =
      core::parse_run_config({{"method", "maps"}, {"data", {{"file", "x.h5"}}}, {"moore", {{"width", 3}}}});
  EXPECT_FALSE(core::to_json(maps_config).contains("moore"));
  EXPECT_THAT(error_of([] {
                core::make_policy(config_of("moore", {{"width", 2}, {"experts", 3}}), kShape);
              }),
              HasSubstr("moore.experts <= moore.width"));
}

// MOORE's pieces: the experts' outputs are orthonormal per state; the task weights of one task change only that
// task's rows; without the orthogonal layer it is the plain mixture of experts.
TEST(MOORE, ExpertOutputsAreOrthonormalPerStateAndTaskWeightsArePerTask) {
  ag::Generator gen(1);
  core::MOORE moore(kShape, {.experts = 3, .layers = 2, .width = 8, .orthogonal = true}, gen);
  const core::Batch batch = make_batch(4, 3, 2);
  const auto u = moore.expert_outputs(batch.observations).to_vector();  // [3, 12, 8]
  for (std::int64_t s = 0; s < 12; ++s)
    for (std::int64_t i = 0; i < 3; ++i)
      for (std::int64_t j = 0; j < 3; ++j) {
        double dot = 0.0;
        for (std::int64_t f = 0; f < 8; ++f)
          dot += u[static_cast<std::size_t>((i * 12 + s) * 8 + f)] * u[static_cast<std::size_t>((j * 12 + s) * 8 + f)];
        EXPECT_NEAR(dot, i == j ? 1.0 : 0.0, 1e-5);
      }
  const ag::Tensor before = moore.act(batch.observations, batch.tasks);
  for (auto [name, p] : moore.named_parameters())
    if (name == "task_weights") {
      ag::NoGradGuard guard;
      auto* w = p.data<float>();
      for (int m = 0; m < 3; ++m) w[1 * 3 + m] += 0.5f;  // task 1's row
    }
  const auto change = (moore.act(batch.observations, batch.tasks) - before).to_vector();
  for (std::int64_t r = 0; r < 12; ++r)
    for (std::int64_t a = 0; a < 2; ++a) {
      const double d = std::abs(change[static_cast<std::size_t>(r * 2 + a)]);
      if (batch.tasks[static_cast<std::size_t>(r)] == 1)
        EXPECT_GT(d, 1e-6) << "row " << r;
      else
        EXPECT_EQ(d, 0.0) << "row " << r;
    }
}

// PaCo: the sets start identical (the public code's use_identical_init), so at first every task's network is the
// first set's scaled by sum_p w_{k,p}.
TEST(PaCo, SetsStartIdenticalAndTaskKUsesThetaEqualsPhiTimesW) {
  ag::Generator gen(3);
  core::PaCo paco(kShape, {.parameter_sets = 3, .layers = 1, .width = 4}, gen);
  for (const auto& [name, tensor] : paco.named_parameters()) {
    if (name.rfind("sets.", 0) != 0) continue;
    const auto values = tensor.to_vector();
    const std::size_t member = values.size() / 3;
    for (std::size_t i = member; i < values.size(); ++i) EXPECT_EQ(values[i], values[i % member]) << name;
  }
  // After training moves the sets apart, a task's action is still the network with theta_k = sum_p w_kp phi_p.
  train(paco, make_batch(4, 8, 4), 20, 1e-2);
  const core::Batch batch = make_batch(4, 2, 5);
  const auto actions = paco.act(batch.observations, batch.tasks).to_vector();
  const auto w = paco.task_weights().to_vector();  // [4, 3]
  std::vector<std::vector<double>> weight(2), bias(2);
  for (const auto& [name, tensor] : paco.named_parameters()) {
    if (name == "sets.0.weight") weight[0] = tensor.to_vector();  // [3, 3, 4]
    if (name == "sets.0.bias") bias[0] = tensor.to_vector();      // [3, 1, 4]
    if (name == "sets.1.weight") weight[1] = tensor.to_vector();  // [3, 4, 2]
    if (name == "sets.1.bias") bias[1] = tensor.to_vector();      // [3, 1, 2]
  }
  const auto obs = batch.observations.to_vector();
  for (std::size_t r = 0; r < batch.tasks.size(); ++r) {
    const std::int64_t k = batch.tasks[r];
    auto theta = [&](int layer, std::size_t index, std::size_t member_size, bool is_bias) {
      double value = 0.0;
      for (std::size_t p = 0; p < 3; ++p)
        value += w[static_cast<std::size_t>(k) * 3 + p] * (is_bias ? bias : weight)[layer][p * member_size + index];
      return value;
    };
    double hidden[4];
    for (std::size_t o = 0; o < 4; ++o) {
      double z = theta(0, o, 4, true);
      for (std::size_t i = 0; i < 3; ++i) z += obs[r * 3 + i] * theta(0, i * 4 + o, 12, false);
      hidden[o] = std::max(0.0, z);
    }
    for (std::size_t a = 0; a < 2; ++a) {
      double z = theta(1, a, 2, true);
      for (std::size_t i = 0; i < 4; ++i) z += hidden[i] * theta(1, i * 2 + a, 8, false);
      EXPECT_NEAR(actions[r * 2 + a], z, 1e-5) << "row " << r;
    }
  }
}

// A task whose loss is out of all proportion (its actions scaled by 100) is left out of the step, and after the
// step its task weights become a convex combination of the other tasks'.
TEST(PaCo, AnExtremeTaskIsMaskedAndItsWeightsResetTowardsTheOthers) {
  ag::Generator gen(6);
  core::PaCo paco(kShape, {.parameter_sets = 3, .layers = 1, .width = 8, .mask_threshold = 30.0}, gen);
  core::Batch batch = make_batch(4, 8, 7);
  {
    auto actions = batch.actions.to_vector();
    for (std::size_t j = 0; j < batch.tasks.size(); ++j)
      if (batch.tasks[j] == 2) actions[2 * j] *= 100.0, actions[2 * j + 1] *= 100.0;
    batch.actions = ag::from_vector(actions, batch.actions.shape(), batch.actions.dtype());
  }
  const core::LossTerms terms = paco.loss(batch);
  ASSERT_EQ(terms.terms.size(), 2u);
  EXPECT_EQ(terms.terms[1].first, "masked_tasks");
  EXPECT_EQ(terms.terms[1].second.item(), 1.0);
  // The loss is the other three tasks' alone.
  const auto unmasked_rows = [&] {
    std::vector<std::int64_t> rows;
    for (std::size_t j = 0; j < batch.tasks.size(); ++j)
      if (batch.tasks[j] != 2) rows.push_back(static_cast<std::int64_t>(j));
    return rows;
  }();
  const ag::Tensor healthy = ag::index_select(paco.act(batch.observations, batch.tasks), unmasked_rows);
  EXPECT_NEAR(terms.total.item(), ag::mse_loss(healthy, ag::index_select(batch.actions, unmasked_rows)).item(), 1e-6);
  terms.total.backward();
  paco.after_step();
  std::vector<double> w;
  for (const auto& [name, tensor] : paco.named_parameters())
    if (name == "task_weights") w = tensor.to_vector();
  for (std::size_t p = 0; p < 3; ++p) {
    double low = 1e9, high = -1e9;
    for (std::size_t k : {0u, 1u, 3u}) low = std::min(low, w[k * 3 + p]), high = std::max(high, w[k * 3 + p]);
    EXPECT_GE(w[2 * 3 + p], low - 1e-6) << "set " << p;
    EXPECT_LE(w[2 * 3 + p], high + 1e-6) << "set " << p;
  }
  // A loss within bounds masks nothing.
  EXPECT_EQ(paco.loss(make_batch(4, 8, 7)).terms[1].second.item(), 0.0);
}

// CARE's paper attends with <E_j(s), z>: the weights move with the state. Its public code's "task" attention gives
// every state of a task the same weights.
TEST(CARE, DotAttentionFollowsTheStateTaskAttentionOnlyTheTask) {
  const core::Batch batch = make_batch(4, 6, 11);
  for (const std::string attention : {"dot", "task"}) {
    ag::Generator gen(12);
    core::CARE care(
        kShape,
        {.encoders = 3, .encoder_width = 8, .context_width = 8, .layers = 1, .width = 8, .attention = attention}, gen);
    const auto alpha = care.routing(batch.observations, batch.tasks).to_vector();  // [24, 3]
    double spread = 0.0;                                                           // within each task
    for (std::size_t r = 0; r < 24; ++r)
      for (std::size_t j = 0; j < 3; ++j)
        spread = std::max(spread, std::abs(alpha[r * 3 + j] - alpha[(r / 6 * 6) * 3 + j]));
    if (attention == "dot")
      EXPECT_GT(spread, 1e-3);
    else
      EXPECT_EQ(spread, 0.0);
  }
}

// Top-k: each row's gate keeps k experts; the importance and load terms are those of the batch; the balancing losses
// keep the gate from collapsing onto one expert, which it does without them.
TEST(TopKMoE, GatesKeepKExpertsAndTheBalancingLossesSpreadTheLoad) {
  const core::Batch batch = make_batch(4, 16, 13);
  auto top_share = [&](double balance) {
    ag::Generator gen(14);
    core::TopKMoE moe(kShape, {.experts = 4, .top_k = 1, .layers = 1, .width = 16, .balance = balance}, gen);
    train(moe, batch, 300, 1e-2);
    const auto gates = moe.routing(batch.observations, batch.tasks).to_vector();  // [64, 4]
    std::vector<double> usage(4, 0.0);
    for (std::size_t r = 0; r < 64; ++r)
      for (std::size_t i = 0; i < 4; ++i) {
        const double g = gates[r * 4 + i];
        EXPECT_TRUE(g == 0.0 || g == 1.0) << "top-1: a row's gate is one expert's (row " << r << ")";
        usage[i] += g / 64.0;
      }
    return *std::max_element(usage.begin(), usage.end());
  };
  const double with_losses = top_share(1.0), without = top_share(0.0);
  EXPECT_LT(with_losses, 0.6) << "with the balancing losses the busiest expert takes " << with_losses;
  EXPECT_GT(without, with_losses) << without << " vs " << with_losses;

  ag::Generator gen(15);
  core::TopKMoE moe(kShape, {.experts = 4, .top_k = 2, .layers = 1, .width = 8}, gen);
  train(moe, batch, 20, 1e-2);
  const auto gates = moe.routing(batch.observations, batch.tasks).to_vector();
  for (std::size_t r = 0; r < 64; ++r)
    EXPECT_EQ(std::count_if(gates.begin() + static_cast<long>(r * 4), gates.begin() + static_cast<long>(r * 4 + 4),
                            [](double g) { return g > 0.0; }),
              2)
        << "row " << r;
  const core::LossTerms terms = moe.loss(batch);
  ASSERT_EQ(terms.terms.size(), 3u);
  EXPECT_NEAR(terms.total.item(),
              terms.terms[0].second.item() + 0.01 * (terms.terms[1].second.item() + terms.terms[2].second.item()),
              1e-6);
}

// The gate's and the load's gradients, checked numerically in float64 (the noise fixed by the batch's seed; the
// top-k choice is piecewise constant, so the check holds away from ties).
TEST(TopKMoE, GradcheckThroughTheGateAndTheLoad) {
  ag::Generator gen(16);
  core::TopKMoE moe(kShape, {.experts = 3, .top_k = 2, .layers = 1, .width = 4}, gen);
  moe.to(ag::Dtype::Float64);
  core::Batch batch = make_batch(4, 2, 17, ag::Dtype::Float64);
  batch.noise_seed = 5;
  // Non-zero gate weights, so that the gate depends on the input.
  for (auto [name, p] : moe.named_parameters())
    if (name == "gate_weight" || name == "noise_weight") {
      ag::NoGradGuard guard;
      ag::Generator init(name.size());
      const auto values = ag::randn(p.shape(), init, ag::Dtype::Float64).to_vector();
      std::copy(values.begin(), values.end(), p.data<double>());
    }
  std::vector<ag::Tensor> parameters;
  for (const auto& [name, p] : moe.named_parameters())
    if (name == "gate_weight" || name == "noise_weight") parameters.push_back(p);
  const auto result = ag::gradcheck(
      "top-k MoE loss", [&](const std::vector<ag::Tensor>&) { return moe.loss(batch).total; }, parameters);
  EXPECT_TRUE(result.ok) << result.message;
}

// Soft Modularization routes on state and task: two states of one task get different routing, and the same state
// under two tasks too.
TEST(SoftModularization, RoutingFollowsStateAndTask) {
  ag::Generator gen(18);
  core::SoftModularization net(
      kShape, {.module_layers = 3, .modules = 2, .module_width = 8, .base_width = 8, .gating_width = 8}, gen);
  const core::Batch batch = make_batch(4, 2, 19);                                 // rows 0, 1: task 0
  const auto routing = net.routing(batch.observations, batch.tasks).to_vector();  // [8, 6]
  double across_states = 0.0;
  for (std::size_t m = 0; m < 6; ++m) across_states = std::max(across_states, std::abs(routing[m] - routing[6 + m]));
  EXPECT_GT(across_states, 1e-6);
  const auto same_state = net.routing(ag::index_select(batch.observations, {0, 0}), {0, 1}).to_vector();
  double across_tasks = 0.0;
  for (std::size_t m = 0; m < 6; ++m)
    across_tasks = std::max(across_tasks, std::abs(same_state[m] - same_state[6 + m]));
  EXPECT_GT(across_tasks, 1e-6);
}

}  // namespace
