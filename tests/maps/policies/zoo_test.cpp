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
#include "nn/optim/adam.h"
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
// With the balancing losses, top-2 gating over four experts on four tasks keeps the busiest expert's share of the
// gate below this (0.25 is perfect balance, 0.5 is two experts doing all the work).
constexpr double BALANCED_BELOW = 0.3;

struct ZooCase {
  std::string method;
  nlohmann::json small;  // the method's own section at test size
  // Keys that make its training loss independent of the rows' order (top-k's noise is drawn per row position).
  nlohmann::json without_noise = nlohmann::json::object();
  // Adam steps to fit the small four-task problem (EachLearnsASmallFourTaskProblem).
  int steps = 600;
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
    // The official initialisation starts the output layer at U(+-3e-3): at this width it needs twice the steps (as
    // does the next).
    {"soft_modularization",
     {{"module_layers", 3}, {"modules", 3}, {"module_width", 16}, {"base_width", 16}, {"gating_width", 16}},
     nlohmann::json::object(),
     1200},
    {"soft_modularization",
     {{"module_layers", 2},
      {"modules", 2},
      {"module_width", 16},
      {"base_width", 16},
      {"gating_width", 16},
      {"aggregation", "sum"}},
     nlohmann::json::object(),
     1200},
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
    EXPECT_FALSE(entry.defaults().empty()) << c.method;
    EXPECT_EQ(core::to_json(config_of(c.method, c.small))[c.method].size(), entry.defaults().size()) << c.method;
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

// Four tasks with different smooth targets, 32 states each: each method fits them in 600 Adam steps (Soft
// Modularization with its official initialisation 1200), from about 0.4 to below 3e-3 (measured at these seeds: moore
// 7.3e-6, paco 9.2e-5, care 7.3e-5 "dot" and 1.1e-4 "task", top_k_moe 1.5e-5 (its total, with the balancing terms),
// soft_modularization 2.7e-4 "softmax" and 4.5e-4 "sum"; the bound leaves a factor of 7 or more).
TEST(Zoo, EachLearnsASmallFourTaskProblem) {
  for (const auto& c : kZoo) {
    const auto policy = core::make_policy(config_of(c.method, c.small, 3), kShape);
    const auto losses = train(*policy, make_batch(4, 32, 4), c.steps, 3e-3);
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
              HasSubstr("config moore.experts: expected an integer in [1, 64], got 2.5"));
  EXPECT_THAT(error_of([] {
                config_of("moore", {{"experts", 0}});
              }),
              HasSubstr("config moore.experts: expected an integer in [1, 64], got 0"));
  EXPECT_THAT(error_of([] {
                config_of("moore", {{"orthogonal", 1}});
              }),
              HasSubstr("config moore.orthogonal: expected true or false, got 1"));
  // CARE's temperature: only the task attention has one, and float32 logits divided by a tiny one overflow.
  EXPECT_THAT(error_of([] {
                config_of("care", {{"temperature", 5.0}});
              }),
              HasSubstr("config care.temperature: only the \"task\" attention has a temperature"));
  EXPECT_THAT(error_of([] {
                config_of("care", {{"attention", "task"}, {"temperature", 1e-40}});
              }),
              HasSubstr("config care.temperature: expected a finite number in [0.001, 1000], got 1e-40"));
  EXPECT_NO_THROW(config_of("care", {{"attention", "task"}, {"temperature", 0.5}}));
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

// The largest |<u_i(s), u_j(s)> - [i == j]| over the states s and expert pairs of outputs u [k, n, F].
double off_orthonormal(const ag::Tensor& outputs) {
  const std::int64_t k = outputs.size(0), n = outputs.size(1), F = outputs.size(2);
  const auto u = outputs.to_vector();
  double worst = 0.0;
  for (std::int64_t s = 0; s < n; ++s)
    for (std::int64_t i = 0; i < k; ++i)
      for (std::int64_t j = 0; j < k; ++j) {
        double dot = 0.0;
        for (std::int64_t f = 0; f < F; ++f)
          dot += u[static_cast<std::size_t>((i * n + s) * F + f)] * u[static_cast<std::size_t>((j * n + s) * F + f)];
        worst = std::max(worst, std::abs(dot - (i == j ? 1.0 : 0.0)));
      }
  return worst;
}

// MOORE's pieces: the experts' outputs are orthonormal per state; the task weights of one task change only that
// task's rows.
TEST(MOORE, ExpertOutputsAreOrthonormalPerStateAndTaskWeightsArePerTask) {
  ag::Generator gen(1);
  core::MOORE moore(kShape, {.experts = 3, .layers = 2, .width = 8, .orthogonal = true}, gen);
  const core::Batch batch = make_batch(4, 3, 2);
  EXPECT_LT(off_orthonormal(moore.expert_outputs(batch.observations)), 1e-5);
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

// Without the orthogonal layer (moore.orthogonal false) the experts' outputs are used as they are: the same
// experts orthonormalised give the orthogonal MOORE's outputs bit for bit, and the raw ones are not orthonormal.
TEST(MOORE, WithoutTheOrthogonalLayerTheExpertOutputsAreMixedAsTheyAre) {
  ag::Generator gen_plain(1), gen_orthogonal(1);
  core::MOORE plain(kShape, {.experts = 3, .layers = 2, .width = 8, .orthogonal = false}, gen_plain);
  core::MOORE orthogonal(kShape, {.experts = 3, .layers = 2, .width = 8, .orthogonal = true}, gen_orthogonal);
  const core::Batch batch = make_batch(4, 3, 2);
  const ag::Tensor raw = plain.expert_outputs(batch.observations);  // [3, 12, 8]
  EXPECT_EQ(ag::gram_schmidt(raw).to_vector(), orthogonal.expert_outputs(batch.observations).to_vector());
  EXPECT_GT(off_orthonormal(raw), 0.1);
  EXPECT_NE(plain.act(batch.observations, batch.tasks).to_vector(),
            orthogonal.act(batch.observations, batch.tasks).to_vector());
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

// A task whose loss is out of all proportion (its actions scaled by 100) is left out of the step (its rows' loss
// zero, the mean over the whole batch), and after the step its task weights become a convex combination of the
// other tasks' ("interpolate", the weights solved for here) or a copy of one of them ("copy").
TEST(PaCo, AnExtremeTaskIsMaskedAndItsWeightsResetTowardsTheOthers) {
  core::Batch batch = make_batch(4, 8, 7);
  {
    auto actions = batch.actions.to_vector();
    for (std::size_t j = 0; j < batch.tasks.size(); ++j)
      if (batch.tasks[j] == 2) actions[2 * j] *= 100.0, actions[2 * j + 1] *= 100.0;
    batch.actions = ag::from_vector(actions, batch.actions.shape(), batch.actions.dtype());
  }
  const std::vector<std::int64_t> healthy_rows = [&] {
    std::vector<std::int64_t> rows;
    for (std::size_t j = 0; j < batch.tasks.size(); ++j)
      if (batch.tasks[j] != 2) rows.push_back(static_cast<std::int64_t>(j));
    return rows;
  }();
  auto task_weights = [](core::PaCo& paco) {
    for (const auto& [name, tensor] : paco.named_parameters())
      if (name == "task_weights") return tensor.to_vector();  // [K, P]
    return std::vector<double>{};
  };
  for (const std::string reset : {"interpolate", "copy"}) {
    ag::Generator gen(6);
    core::PaCo paco(kShape, {.parameter_sets = 3, .layers = 1, .width = 8, .mask_threshold = 30.0, .reset = reset},
                    gen);
    const core::LossTerms terms = paco.loss(batch);
    ASSERT_EQ(terms.terms.size(), 2u);
    EXPECT_EQ(terms.terms[1].first, "masked_tasks");
    EXPECT_EQ(terms.terms[1].second.item(), 1.0);
    // The other three tasks' squared error, summed over their rows and divided by all 32 rows.
    const ag::Tensor healthy = ag::index_select(paco.act(batch.observations, batch.tasks), healthy_rows);
    EXPECT_NEAR(terms.total.item(),
                ag::mse_loss(healthy, ag::index_select(batch.actions, healthy_rows)).item() * 24.0 / 32.0, 1e-6);
    const std::vector<double> before = task_weights(paco);
    terms.total.backward();
    paco.after_step();
    const std::vector<double> w = task_weights(paco);
    const std::vector<std::size_t> others{0, 1, 3};
    double moved = 0.0;
    for (std::size_t p = 0; p < 3; ++p) moved += std::abs(w[2 * 3 + p] - before[2 * 3 + p]);
    EXPECT_GT(moved, 1e-3) << reset << ": task 2's weights did not move";
    for (std::size_t k : others)
      for (std::size_t p = 0; p < 3; ++p) EXPECT_EQ(w[k * 3 + p], before[k * 3 + p]) << reset << ": task " << k;
    // Solve w_2 = sum_h lambda_h w_h over the three healthy tasks (Cramer's rule on the 3 x 3 system).
    auto m = [&](std::size_t p, std::size_t h) { return w[others[h] * 3 + p]; };
    auto det = [&](auto&& at) {
      return at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1)) -
             at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0)) +
             at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0));
    };
    const double d = det(m);
    ASSERT_GT(std::abs(d), 1e-9);
    std::vector<double> lambda(3);
    for (std::size_t h = 0; h < 3; ++h)
      lambda[h] = det([&](std::size_t p, std::size_t c) { return c == h ? w[2 * 3 + p] : m(p, c); }) / d;
    EXPECT_NEAR(lambda[0] + lambda[1] + lambda[2], 1.0, 1e-6) << reset;
    for (std::size_t h = 0; h < 3; ++h) EXPECT_GE(lambda[h], -1e-6) << reset << ": weight of task " << others[h];
    if (reset == "copy") {
      EXPECT_EQ(std::count_if(lambda.begin(), lambda.end(), [](double l) { return std::abs(l - 1.0) < 1e-6; }), 1);
    }
    // A loss within bounds masks nothing.
    EXPECT_EQ(paco.loss(make_batch(4, 8, 7)).terms[1].second.item(), 0.0);
  }
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

// A float64 MoE's gate and noise weights [S + K, E] (zero at construction) set to standard normal draws seeded by each
// name's length plus `seed`, so that the gate depends on the input; returns the two, for gradcheck.
std::vector<ag::Tensor> randomize_gate(core::TopKMoE& moe, std::size_t seed) {
  std::vector<ag::Tensor> gate_parameters;
  for (auto [name, p] : moe.named_parameters())
    if (name == "gate_weight" || name == "noise_weight") {
      ag::NoGradGuard guard;
      ag::Generator init(name.size() + seed);
      const auto values = ag::randn(p.shape(), init, ag::Dtype::Float64).to_vector();
      std::copy(values.begin(), values.end(), p.data<double>());
      gate_parameters.push_back(p);
    }
  return gate_parameters;
}

// Top-k: each row's gate keeps k experts, and the balancing losses spread the load. Trained with fresh gate noise
// every step (as maps train draws it), at the default weight 0.01 the squared coefficient of variation of the
// experts' gate mass (noise-free, over the batch) is a tenth or less of what it is without the losses (measured:
// 0.0017 against 0.12; without them this small problem leaves one expert with a third of the mass, not all of it).
TEST(TopKMoE, GatesKeepKExpertsAndTheBalancingLossesSpreadTheLoad) {
  const core::Batch batch = make_batch(4, 16, 13);
  struct Spread {
    double busiest, cv_squared;
  };
  auto spread = [&](double balance) {
    ag::Generator gen(14);
    core::TopKMoE moe(kShape, {.experts = 4, .top_k = 2, .layers = 1, .width = 16, .balance = balance}, gen);
    maps::optim::Adam adam(moe.parameters(), {.lr = 1e-2});
    core::Batch noisy = batch;
    for (std::uint64_t step = 0; step < 300; ++step) {
      noisy.noise_seed = step;
      adam.zero_grad();
      moe.loss(noisy).total.backward();
      adam.step();
    }
    const auto gates = moe.routing(batch.observations, batch.tasks).to_vector();  // [64, 4]
    std::vector<double> usage(4, 0.0);
    for (std::size_t r = 0; r < 64; ++r) {
      EXPECT_EQ(std::count_if(gates.begin() + static_cast<long>(r * 4), gates.begin() + static_cast<long>(r * 4 + 4),
                              [](double g) { return g > 0.0; }),
                2)
          << "row " << r;
      for (std::size_t i = 0; i < 4; ++i) usage[i] += gates[r * 4 + i] / 64.0;
    }
    double variance = 0.0;  // the mean share is 1/4: each row's gate sums to 1
    for (double u : usage) variance += (u - 0.25) * (u - 0.25) / 3.0;
    return Spread{*std::max_element(usage.begin(), usage.end()), variance / (0.25 * 0.25)};
  };
  const Spread with_losses = spread(0.01), without = spread(0.0);
  EXPECT_LT(with_losses.busiest, BALANCED_BELOW)
      << "with the balancing losses the busiest expert takes " << with_losses.busiest;
  EXPECT_LT(10.0 * with_losses.cv_squared, without.cv_squared)
      << with_losses.cv_squared << " vs " << without.cv_squared;
}

// The importance and load terms of a four-row batch, recomputed here from their definitions: noisy logits
// H = x W_g + eps (softplus(x W_noise) + 0.01), G = softmax over each row's top 2, importance = sum of G per expert,
// load = sum of Phi((clean_i - threshold_i) / sigma_i), threshold the 3rd largest H for a chosen expert and the
// 2nd for the other; each term CV^2 = unbiased variance / (mean^2 + 1e-10).
TEST(TopKMoE, ImportanceAndLoadAreTheHandComputedOnes) {
  ag::Generator gen(20);
  core::TopKMoE moe(kShape, {.experts = 3, .top_k = 2, .layers = 1, .width = 4}, gen);
  moe.to(ag::Dtype::Float64);
  const std::int64_t S = 3, K = 4, E = 3, in = S + K;
  std::vector<double> wg(static_cast<std::size_t>(in * E)), wn(wg.size());
  for (std::size_t i = 0; i < wg.size(); ++i) {
    wg[i] = 0.8 * std::sin(1.7 * static_cast<double>(i) + 0.3);
    wn[i] = 0.5 * std::cos(2.3 * static_cast<double>(i) + 0.1);
  }
  for (auto [name, p] : moe.named_parameters()) {
    ag::NoGradGuard guard;
    if (name == "gate_weight") std::copy(wg.begin(), wg.end(), p.data<double>());
    if (name == "noise_weight") std::copy(wn.begin(), wn.end(), p.data<double>());
  }
  core::Batch batch = make_batch(K, 1, 21, ag::Dtype::Float64);
  batch.noise_seed = 7;
  const auto obs = batch.observations.to_vector();
  const auto eps = core::TopKMoE::gate_noise(K, E, 7, ag::Dtype::Float64).to_vector();
  std::vector<double> importance(E, 0.0), load(E, 0.0);
  for (std::int64_t r = 0; r < K; ++r) {
    std::vector<double> x(static_cast<std::size_t>(in), 0.0);
    for (std::int64_t j = 0; j < S; ++j) x[static_cast<std::size_t>(j)] = obs[static_cast<std::size_t>(r * S + j)];
    x[static_cast<std::size_t>(S + batch.tasks[static_cast<std::size_t>(r)])] = 1.0;
    std::vector<double> clean(E, 0.0), sigma(E, 0.0), noisy(E, 0.0);
    for (std::int64_t i = 0; i < E; ++i) {
      double c = 0.0, z = 0.0;
      for (std::int64_t j = 0; j < in; ++j) {
        c += x[static_cast<std::size_t>(j)] * wg[static_cast<std::size_t>(j * E + i)];
        z += x[static_cast<std::size_t>(j)] * wn[static_cast<std::size_t>(j * E + i)];
      }
      clean[static_cast<std::size_t>(i)] = c;
      sigma[static_cast<std::size_t>(i)] = std::log1p(std::exp(z)) + 0.01;
      noisy[static_cast<std::size_t>(i)] =
          c + eps[static_cast<std::size_t>(r * E + i)] * sigma[static_cast<std::size_t>(i)];
    }
    std::vector<std::size_t> order{0, 1, 2};
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return noisy[a] > noisy[b]; });
    const double top = std::exp(noisy[order[0]]), second = std::exp(noisy[order[1]]);
    importance[order[0]] += top / (top + second);
    importance[order[1]] += second / (top + second);
    for (std::size_t i = 0; i < 3; ++i) {
      const bool chosen = i == order[0] || i == order[1];
      const double threshold = noisy[chosen ? order[2] : order[1]];
      load[i] += 0.5 * (1.0 + std::erf((clean[i] - threshold) / sigma[i] / std::sqrt(2.0)));
    }
  }
  auto cv_squared = [](const std::vector<double>& v) {
    const double m = (v[0] + v[1] + v[2]) / 3.0;
    const double var = ((v[0] - m) * (v[0] - m) + (v[1] - m) * (v[1] - m) + (v[2] - m) * (v[2] - m)) / 2.0;
    return var / (m * m + 1e-10);
  };
  const core::LossTerms terms = moe.loss(batch);
  ASSERT_EQ(terms.terms.size(), 3u);
  EXPECT_EQ(terms.terms[1].first, "importance");
  EXPECT_EQ(terms.terms[2].first, "load");
  EXPECT_GT(cv_squared(importance), 1e-3);  // the batch is unbalanced enough for the check to mean something
  EXPECT_NEAR(terms.terms[1].second.item(), cv_squared(importance), 1e-12);
  EXPECT_NEAR(terms.terms[2].second.item(), cv_squared(load), 1e-12);
  EXPECT_NEAR(terms.total.item(), terms.terms[0].second.item() + 0.01 * (cv_squared(importance) + cv_squared(load)),
              1e-12);
}

// Under PPO (GAIL) the mean actions are act()'s, whose log-probabilities the rollouts took, and the balancing terms
// ride along: importance on that noiseless gate, load on the batch's noisy one (as loss() computes it).
TEST(TopKMoE, ForwardTermsAreActsActionsWithTheBalancingTerms) {
  ag::Generator gen(24);
  core::TopKMoE moe(kShape, {.experts = 3, .top_k = 2, .layers = 1, .width = 4}, gen);
  moe.to(ag::Dtype::Float64);
  randomize_gate(moe, 3);
  core::Batch batch = make_batch(4, 3, 25, ag::Dtype::Float64);
  batch.noise_seed = 11;
  const core::PolicyForward forward = moe.forward_terms(batch);
  EXPECT_EQ(max_abs_diff(forward.mean_actions, moe.act(batch.observations, batch.tasks)), 0.0);
  ASSERT_EQ(forward.regularizer.terms.size(), 2u);
  EXPECT_EQ(forward.regularizer.terms[0].first, "importance");
  EXPECT_EQ(forward.regularizer.terms[1].first, "load");
  const auto gates = moe.routing(batch.observations, batch.tasks).to_vector();  // [12, 3], noiseless
  std::vector<double> importance(3, 0.0);
  for (std::size_t r = 0; r < 12; ++r)
    for (std::size_t i = 0; i < 3; ++i) importance[i] += gates[r * 3 + i];
  const double m = (importance[0] + importance[1] + importance[2]) / 3.0;
  double var = 0.0;
  for (double v : importance) var += (v - m) * (v - m) / 2.0;
  EXPECT_NEAR(forward.regularizer.terms[0].second.item(), var / (m * m + 1e-10), 1e-12);
  const core::LossTerms noisy = moe.loss(batch);
  EXPECT_NEAR(forward.regularizer.terms[1].second.item(), noisy.terms[2].second.item(), 1e-12);
  EXPECT_GT(forward.regularizer.terms[1].second.item(), 0.0);
  EXPECT_NEAR(forward.regularizer.total.item(),
              0.01 * (forward.regularizer.terms[0].second.item() + forward.regularizer.terms[1].second.item()), 1e-12);
}

// The balancing losses alone (no BC term), their gradient in the gate's weights checked numerically in float64.
TEST(TopKMoE, GradcheckOfTheBalancingLossesAlone) {
  ag::Generator gen(22);
  core::TopKMoE moe(kShape, {.experts = 4, .top_k = 2, .layers = 1, .width = 4}, gen);
  moe.to(ag::Dtype::Float64);
  core::Batch batch = make_batch(4, 3, 23, ag::Dtype::Float64);
  batch.noise_seed = 9;
  const std::vector<ag::Tensor> parameters = randomize_gate(moe, 1);
  const auto result = ag::gradcheck(
      "top-k MoE importance + load",
      [&](const std::vector<ag::Tensor>&) {
        const core::LossTerms terms = moe.loss(batch);
        return terms.terms[1].second + terms.terms[2].second;
      },
      parameters);
  EXPECT_TRUE(result.ok) << result.message;
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
  const std::vector<ag::Tensor> parameters = randomize_gate(moe, 0);
  const auto result = ag::gradcheck(
      "top-k MoE loss", [&](const std::vector<ag::Tensor>&) { return moe.loss(batch).total; }, parameters);
  EXPECT_TRUE(result.ok) << result.message;
}

// Soft Modularization routes on state and task: two states of one task get different routing, and the same state
// under two tasks too.
TEST(SoftModularization, RoutingFollowsStateAndTask) {
  ag::Generator gen(18);
  core::SoftModularization net(
      kShape,
      // torch.nn.Linear's initialisation: the official one starts the routing within 1e-6 of uniform everywhere.
      {.module_layers = 3, .modules = 2, .module_width = 8, .base_width = 8, .gating_width = 8, .init = "pytorch"},
      gen);
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

TEST(SoftModularization, OfficialInitStartsRoutingUniformAndActionsNearZero) {
  // The official code's initialisation (the default): the routing heads and the output layer start at U(+-3e-3), so
  // every routing share starts within a few percent of uniform and every action near 0; torch.nn.Linear's does not.
  const core::Batch batch = make_batch(4, 2, 19);
  auto start = [&](const std::string& init) {
    ag::Generator gen(18);
    core::SoftModularization net(
        kShape,
        {.module_layers = 3, .modules = 4, .module_width = 16, .base_width = 16, .gating_width = 16, .init = init},
        gen);
    const double uniform = 1.0 / (4.0 * 3.0);
    double routing_off = 0.0, largest_action = 0.0;
    for (double share : net.routing(batch.observations, batch.tasks).to_vector())
      routing_off = std::max(routing_off, std::abs(share - uniform) / uniform);
    for (double a : net.act(batch.observations, batch.tasks).to_vector())
      largest_action = std::max(largest_action, std::abs(a));
    return std::pair{routing_off, largest_action};
  };
  const auto [official_routing, official_action] = start("official");
  EXPECT_LT(official_routing, 0.05);
  EXPECT_LT(official_action, 0.05);
  const auto [pytorch_routing, pytorch_action] = start("pytorch");
  EXPECT_GT(pytorch_routing, 2 * official_routing);
  EXPECT_GT(pytorch_action, 2 * official_action);
  ag::Generator gen(1);
  EXPECT_THAT(error_of([&] { core::SoftModularization(kShape, {.init = "xavier"}, gen); }),
              HasSubstr("SoftModularization: init: expected \"official\""));
  EXPECT_THAT(error_of([] {
                config_of("soft_modularization", {{"init", "xavier"}});
              }),
              HasSubstr("config soft_modularization.init: expected \"official\""));
}

}  // namespace
