// The zoo's modular methods (docs/zoo.md), each through the registry as `maps train` builds it: its parameter count
// as the registry estimates it, the width matched to MAPS's, learning a small four-task problem, the same actions on
// balanced and mixed batches, and routing shares that are a distribution over its modules.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "maps/policies/moore.h"
#include "maps/policies/policy_registry.h"
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
};

// The methods added after the paper, each at a size that trains in a second.
const std::vector<ZooCase> kZoo = {
    {"moore", {{"experts", 3}, {"layers", 2}, {"width", 32}}},
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

// Four tasks with different smooth targets, 32 states each: each method fits them in 600 Adam steps (measured at
// these seeds: moore 0.39 -> 7.3e-6; the bound leaves a factor of 100 for other seeds and platforms).
TEST(Zoo, EachLearnsASmallFourTaskProblem) {
  for (const auto& c : kZoo) {
    const auto policy = core::make_policy(config_of(c.method, c.small, 3), kShape);
    const auto losses = train(*policy, make_batch(4, 32, 4), 600, 3e-3);
    EXPECT_LT(losses.back(), 1e-3) << c.method << ": " << losses.front() << " -> " << losses.back();
  }
}

TEST(Zoo, MixedRowsActAsInTheBalancedBatch) {
  for (const auto& c : kZoo) {
    const auto policy = core::make_policy(config_of(c.method, c.small, 5), kShape);
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

}  // namespace
