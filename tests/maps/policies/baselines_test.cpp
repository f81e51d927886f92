#include <memory>

#include "baseline_test_util.h"
#include "maps/policies/mt_bc.h"
#include "maps/policies/mt_mh_bc.h"
#include "maps/policies/single_bc.h"
#include "nn/mlp.h"

namespace baselinetest {
namespace {

const core::PolicyShape kShape{3, 2, 3};  // S, A, K

// ---------------------------------------------------------------- SingleBC

TEST(SingleBC, ParametersAreKStackedPaperMLPs) {
  ag::Generator gen(1);
  core::SingleBC policy(kShape, gen);
  const auto named = policy.named_parameters();
  ASSERT_EQ(named.size(), 8u);
  EXPECT_EQ(named[0].name, "layers.0.weight");
  EXPECT_EQ(named[0].tensor.shape(), (ag::Shape{3, 3, 128}));
  EXPECT_EQ(named[7].name, "layers.3.bias");
  EXPECT_EQ(named[7].tensor.shape(), (ag::Shape{3, 1, 2}));
  // K copies of S -> 128 -> 128 -> 128 -> A.
  const std::int64_t one = (3 * 128 + 128) + 2 * (128 * 128 + 128) + (128 * 2 + 2);
  EXPECT_EQ(policy.parameter_count(), 3 * one);
}

TEST(SingleBC, ActOnMixedTasksMatchesTheBalancedPath) {
  ag::Generator gen(2);
  core::SingleBC policy(kShape, gen, {16, 16});
  const core::Batch batch = make_batch(3, 5, 3);
  const Tensor balanced = policy.predict(batch);
  ASSERT_EQ(balanced.shape(), (ag::Shape{15, 2}));
  const std::vector<std::int64_t> rows = shuffled_rows(15, 4);
  const core::Batch mixed = rows_of(batch, rows);
  const Tensor acted = policy.act(mixed.observations, mixed.tasks);
  EXPECT_LT(max_abs_diff(acted, ag::index_select(balanced, rows)), 1e-6);
  // And each row equals running its own task's network alone.
  const Tensor all = policy.forward_all(mixed.observations);  // [K, n, A]
  for (std::int64_t j = 0; j < 15; ++j) {
    const std::int64_t k = mixed.tasks[static_cast<std::size_t>(j)];
    const Tensor own = ag::narrow(ag::narrow(all, 0, k, 1), 1, j, 1).reshape({1, 2});
    EXPECT_LT(max_abs_diff(ag::narrow(acted, 0, j, 1), own), 1e-7);
  }
  // The loss of a shuffled (unbalanced) batch is the balanced one's.
  EXPECT_NEAR(policy.loss(mixed).total.item(), policy.loss(batch).total.item(), 1e-6);
}

// act() regroups rows by task (padding the shorter groups): uneven counts, a task with no rows and one row alone
// give each row its own network's output, and the parameters' gradients, as running every network on every row.
TEST(SingleBC, ActOnUnevenTasksEqualsEveryNetworkOnEveryRowInValueAndGradient) {
  ag::Generator gen(11);
  core::SingleBC policy(kShape, gen, {16, 16});
  const core::Batch batch = make_batch(3, 5, 12);
  const std::vector<std::int64_t> rows{14, 0, 3, 1, 4, 2, 13};  // task 0 five rows, task 1 none, task 2 two
  const core::Batch uneven = rows_of(batch, rows);
  const Tensor acted = policy.act(uneven.observations, uneven.tasks);
  const Tensor every = ag::index_select(ag::reshape(policy.forward_all(uneven.observations), {-1, 2}),
                                        core::own_task_rows(uneven.tasks));
  EXPECT_LT(max_abs_diff(acted, every), 1e-6);
  const auto gradients = [&](const Tensor& out) {
    policy.zero_grad();
    ag::sum(ag::square(out)).backward();
    std::vector<Tensor> grads;
    for (const Tensor& p : policy.parameters()) grads.push_back(p.grad().clone());
    return grads;
  };
  const std::vector<Tensor> grouped = gradients(policy.act(uneven.observations, uneven.tasks));
  const std::vector<Tensor> reference = gradients(ag::index_select(
      ag::reshape(policy.forward_all(uneven.observations), {-1, 2}), core::own_task_rows(uneven.tasks)));
  ASSERT_EQ(grouped.size(), reference.size());
  for (std::size_t i = 0; i < grouped.size(); ++i) EXPECT_LT(max_abs_diff(grouped[i], reference[i]), 1e-5) << i;
  // Task 1 has no rows: its network gets no gradient at all.
  const Tensor first = policy.parameter("layers.0.weight").grad();  // [K, S, 16]
  EXPECT_EQ(max_abs_diff(ag::narrow(grouped[0], 0, 1, 1), ag::zeros_like(ag::narrow(first, 0, 1, 1))), 0.0);
  // One row of one task alone.
  const core::Batch one = rows_of(batch, {7});
  EXPECT_LT(max_abs_diff(policy.act(one.observations, one.tasks),
                         ag::narrow(policy.forward_all(one.observations), 0, 1, 1).reshape({1, 2})),
            1e-6);
  // No rows at all: no actions, and no error.
  EXPECT_EQ(policy.act(ag::zeros({0, 3}, ag::Dtype::Float32), {}).shape(), (ag::Shape{0, 2}));
  // PPO's balanced minibatches take predict()'s path.
  EXPECT_EQ(max_abs_diff(policy.forward_terms(batch).mean_actions, policy.predict(batch)), 0.0);
}

TEST(SingleBC, ChangingOneTasksNetworkChangesOnlyItsRows) {
  ag::Generator gen(5);
  core::SingleBC policy(kShape, gen, {8});
  const core::Batch mixed = rows_of(make_batch(3, 4, 6), shuffled_rows(12, 7));
  const Tensor before = policy.act(mixed.observations, mixed.tasks);
  {
    ag::NoGradGuard no_grad;
    Tensor w = policy.parameter("layers.1.weight");  // [K, 8, A]
    float* data = w.data<float>();
    for (std::int64_t e = 0; e < 8 * 2; ++e) data[1 * 8 * 2 + e] += 0.5f;
  }
  const Tensor after = policy.act(mixed.observations, mixed.tasks);
  for (std::int64_t j = 0; j < 12; ++j) {
    const double change = max_abs_diff(ag::narrow(before, 0, j, 1), ag::narrow(after, 0, j, 1));
    if (mixed.tasks[static_cast<std::size_t>(j)] == 1)
      EXPECT_GT(change, 1e-3) << "row " << j;
    else
      EXPECT_EQ(change, 0.0) << "row " << j;
  }
}

TEST(SingleBC, CloneIsIndependentAndAgrees) {
  ag::Generator gen(8);
  auto policy = std::make_shared<core::SingleBC>(kShape, gen, std::vector<std::int64_t>{8});
  auto copy = maps::nn::clone(policy);
  const core::Batch batch = make_batch(3, 2, 9);
  EXPECT_EQ(max_abs_diff(copy->predict(batch), policy->predict(batch)), 0.0);
  Tensor bias = copy->parameter("layers.0.bias");
  bias.fill_(1.0);
  EXPECT_GT(max_abs_diff(copy->predict(batch), policy->predict(batch)), 1e-3);
}

// ---------------------------------------------------------------- MTBC

TEST(MTBC, OneMLPOnStateAndTaskOneHot) {
  ag::Generator gen(10);
  core::MTBC policy(kShape, gen);
  const auto named = policy.named_parameters();
  ASSERT_EQ(named.size(), 8u);
  EXPECT_EQ(named[0].name, "mlp.layers.0.weight");
  EXPECT_EQ(named[0].tensor.shape(), (ag::Shape{128, 3 + 3}));
  EXPECT_EQ(named[6].tensor.shape(), (ag::Shape{2, 128}));
  // The same state gives different actions under different tasks, and equals the MLP on [s, onehot(k)].
  const Tensor s = ag::from_vector(std::vector<double>{0.1, -0.2, 0.3}, {1, 3});
  const Tensor obs = ag::concat({s, s, s}, 0);
  const Tensor a = policy.act(obs, {0, 1, 2});
  EXPECT_GT(max_abs_diff(ag::narrow(a, 0, 0, 1), ag::narrow(a, 0, 1, 1)), 1e-4);
  auto& mlp = static_cast<maps::nn::MLP&>(*policy.named_children()[0].module);
  const Tensor expected = mlp.forward(ag::concat({obs, ag::one_hot({0, 1, 2}, 3)}, 1));
  EXPECT_LT(max_abs_diff(a, expected), 1e-7);
}

// ---------------------------------------------------------------- MTMHBC

TEST(MTMHBC, SharedTrunkAndOneHeadPerTask) {
  ag::Generator gen(11);
  core::MTMHBC policy(kShape, gen);
  const auto named = policy.named_parameters();
  ASSERT_EQ(named.size(), 8u);
  EXPECT_EQ(named[0].name, "trunk.layers.0.weight");
  EXPECT_EQ(named[5].name, "trunk.layers.2.bias");
  EXPECT_EQ(named[6].name, "heads.weight");
  EXPECT_EQ(named[6].tensor.shape(), (ag::Shape{3, 128, 2}));
  EXPECT_EQ(named[7].tensor.shape(), (ag::Shape{3, 1, 2}));
}

TEST(MTMHBC, RowUsesItsOwnTasksHead) {
  ag::Generator gen(12);
  core::MTMHBC policy(kShape, gen, {16, 16});
  const core::Batch mixed = rows_of(make_batch(3, 4, 13), shuffled_rows(12, 14));
  const Tensor acted = policy.act(mixed.observations, mixed.tasks);
  // By hand: tanh trunk features (tanh after the last trunk layer too), then head k = features W_k + b_k.
  auto& trunk = static_cast<maps::nn::MLP&>(*policy.named_children()[0].module);
  EXPECT_TRUE(trunk.activate_last());
  const Tensor features = trunk.forward(mixed.observations);
  const Tensor w = policy.parameter("heads.weight"), b = policy.parameter("heads.bias");
  for (std::int64_t j = 0; j < 12; ++j) {
    const std::int64_t k = mixed.tasks[static_cast<std::size_t>(j)];
    const Tensor expected = ag::matmul(ag::narrow(features, 0, j, 1), ag::narrow(w, 0, k, 1).reshape({16, 2})) +
                            ag::narrow(b, 0, k, 1).reshape({1, 2});
    EXPECT_LT(max_abs_diff(ag::narrow(acted, 0, j, 1), expected), 1e-6) << "row " << j;
  }
  // The balanced path agrees with act().
  const core::Batch batch = make_batch(3, 4, 13);
  const std::vector<std::int64_t> rows = shuffled_rows(12, 14);
  EXPECT_LT(max_abs_diff(ag::index_select(policy.predict(batch), rows), acted), 1e-6);
}

TEST(MTMHBC, ChangingOneHeadChangesOnlyItsTasksRows) {
  ag::Generator gen(15);
  core::MTMHBC policy(kShape, gen, {8});
  const core::Batch mixed = rows_of(make_batch(3, 4, 16), shuffled_rows(12, 17));
  const Tensor before = policy.act(mixed.observations, mixed.tasks);
  {
    Tensor b = policy.parameter("heads.bias");  // [K, 1, A]
    b.data<float>()[2 * 2 + 0] += 1.0f;         // task 2's first action
  }
  const Tensor after = policy.act(mixed.observations, mixed.tasks);
  for (std::int64_t j = 0; j < 12; ++j) {
    const double change = max_abs_diff(ag::narrow(before, 0, j, 1), ag::narrow(after, 0, j, 1));
    EXPECT_NEAR(change, mixed.tasks[static_cast<std::size_t>(j)] == 2 ? 1.0 : 0.0, 1e-6) << "row " << j;
  }
}

// ---------------------------------------------------------------- every BC baseline

// Two tasks with different targets on the same kind of states: 16 states each.
template <typename P>
std::vector<double> overfit(std::uint64_t seed, int steps, double lr) {
  ag::Generator gen(seed);
  P policy(core::PolicyShape{3, 2, 2}, gen);
  return train(policy, make_batch(2, 16, seed + 1), steps, lr);
}

// Measured at these seeds: 0.32 -> 2.6e-5 (SingleBC), 0.33 -> 3.8e-5 (MTBC), 0.32 -> 1.9e-5 (MTMHBC); over 12
// seeds the final loss stayed below 2e-4, so 2e-3 leaves a factor of 10 for platform differences.
TEST(Baselines, EachOverfitsATinyTwoTaskDataset) {
  const std::vector<std::pair<std::string, std::vector<double>>> runs{
      {"SingleBC", overfit<core::SingleBC>(20, 400, 3e-3)},
      {"MTBC", overfit<core::MTBC>(20, 400, 3e-3)},
      {"MTMHBC", overfit<core::MTMHBC>(20, 400, 3e-3)}};
  for (const auto& [name, losses] : runs) {
    EXPECT_GT(losses.front(), 0.2) << name;
    EXPECT_LT(losses.back(), 2e-3) << name << ": " << losses.front() << " -> " << losses.back();
  }
}

// Single BC trains each task alone: a task's network gets gradient only from its own task's rows.
TEST(SingleBC, EachNetworkLearnsOnlyFromItsOwnTask) {
  ag::Generator gen(23);
  core::SingleBC policy(kShape, gen, {8});
  const core::Batch batch = make_batch(3, 4, 24);
  core::Batch changed = batch;
  changed.actions = batch.actions.clone();
  changed.actions.data<float>()[0] += 1.0f;  // a task-0 row
  const auto grads = ag::grad({policy.loss(batch).total}, policy.parameters());
  const auto changed_grads = ag::grad({policy.loss(changed).total}, policy.parameters());
  for (std::size_t i = 0; i < grads.size(); ++i) {
    EXPECT_GT(max_abs_diff(ag::narrow(grads[i], 0, 0, 1), ag::narrow(changed_grads[i], 0, 0, 1)), 0.0) << i;
    EXPECT_EQ(max_abs_diff(ag::narrow(grads[i], 0, 1, 2), ag::narrow(changed_grads[i], 0, 1, 2)), 0.0) << i;
  }
}

// ---------------------------------------------------------------- errors

template <typename P>
void expect_named_errors(const std::string& name) {
  ag::Generator gen(30);
  P policy(kShape, gen, {4});
  const core::Batch good = make_batch(3, 2, 31);
  EXPECT_THAT(error_of([&] {
                policy.act(ag::zeros({2, 4}), {0, 1});
              }),
              AllOf(HasSubstr(name + "::act"), HasSubstr("expected observations [n, 3]"), HasSubstr("[2, 4]")));
  EXPECT_THAT(error_of([&] {
                policy.act(ag::zeros({2, 3}), {0, 3});
              }),
              AllOf(HasSubstr(name + "::act"), HasSubstr("task 3 at row 1"), HasSubstr("[0, 3)")));
  EXPECT_THAT(error_of([&] { policy.act(ag::zeros({2, 3}), {-1, 0}); }), HasSubstr("task -1 at row 0"));
  EXPECT_THAT(error_of([&] {
                policy.act(ag::zeros({2, 3}), {0});
              }),
              AllOf(HasSubstr(name + "::act"), HasSubstr("one task index per observation row")));
  core::Batch bad_actions = good;
  bad_actions.actions = ag::zeros({6, 3});
  EXPECT_THAT(error_of([&] { policy.loss(bad_actions); }),
              AllOf(HasSubstr(name + "::loss"), HasSubstr("expected actions [6, 2]"), HasSubstr("[6, 3]")));
  core::Batch not_grouped = good;
  std::swap(not_grouped.tasks[1], not_grouped.tasks[2]);
  EXPECT_THAT(error_of([&] { policy.loss(not_grouped); }),
              AllOf(HasSubstr(name + "::loss"), HasSubstr("task-major"), HasSubstr("row 1 should be task 0")));
  core::Batch wrong_count = good;
  wrong_count.per_task = 3;
  EXPECT_THAT(error_of([&] { policy.loss(wrong_count); }),
              AllOf(HasSubstr(name + "::loss"), HasSubstr("must hold 9 rows, got 6")));
  EXPECT_THAT(error_of([&] {
                P(core::PolicyShape{3, 0, 2}, gen);
              }),
              AllOf(HasSubstr(name + ": observation_size, action_size and num_tasks must be positive")));
  EXPECT_THAT(error_of([&] { P(kShape, gen, {8, 0}); }), HasSubstr(name + ": hidden layer sizes must be positive"));
}

TEST(Baselines, BadInputErrorsNameTheClass) {
  expect_named_errors<core::SingleBC>("SingleBC");
  expect_named_errors<core::MTBC>("MTBC");
  expect_named_errors<core::MTMHBC>("MTMHBC");
  ag::Generator gen(32);
  EXPECT_THAT(error_of([&] { core::MTMHBC(kShape, gen, {}); }), HasSubstr("MTMHBC: expected at least one hidden"));
}

}  // namespace
}  // namespace baselinetest
