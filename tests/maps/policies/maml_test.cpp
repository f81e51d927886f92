#include "maps/policies/maml.h"

#include <cmath>
#include <memory>

#include "baseline_test_util.h"
#include "envs/demo_file.h"
#include "maps/data/demo_dataset.h"

namespace baselinetest {
namespace {

// S = 3, A = 2, K = 2; a tiny network so that finite differences over every parameter stay cheap.
std::shared_ptr<core::MAML> tiny_maml(const core::MAMLConfig& config, std::uint64_t seed,
                                      std::vector<std::int64_t> hidden = {4}) {
  ag::Generator gen(seed);
  auto maml = std::make_shared<core::MAML>(core::PolicyShape{3, 2, 2}, gen, config, hidden);
  maml->to(Dtype::Float64);
  return maml;
}

core::MAMLConfig config_with(double inner_lr, std::int64_t query, bool first_order = false, int inner_steps = 1) {
  core::MAMLConfig c;
  c.inner_lr = inner_lr;
  c.query_per_task = query;
  c.first_order = first_order;
  c.inner_steps = inner_steps;
  return c;
}

// The rows [start, start + length) of every task block of a balanced batch, as one balanced batch.
core::Batch task_blocks(const core::Batch& b, std::int64_t start, std::int64_t length) {
  std::vector<std::int64_t> rows;
  const std::int64_t tasks = b.size() / b.per_task;
  for (std::int64_t k = 0; k < tasks; ++k)
    for (std::int64_t i = 0; i < length; ++i) rows.push_back(k * b.per_task + start + i);
  core::Batch out = rows_of(b, rows);
  out.per_task = length;
  return out;
}

TEST(MAMLPolicy, BatchPerTaskAddsTheQueryRows) {
  ag::Generator gen(1);
  core::MAML maml(core::PolicyShape{3, 2, 5}, gen);
  EXPECT_EQ(maml.config().query_per_task, 160);
  EXPECT_EQ(maml.support_per_task(), 0);
  EXPECT_EQ(maml.batch_per_task(128), 288);
  EXPECT_EQ(maml.support_per_task(), 128);
  // The policy sees the state only: S -> 128 -> 128 -> 128 -> A.
  const auto named = maml.named_parameters();
  ASSERT_EQ(named.size(), 8u);
  EXPECT_EQ(named[0].name, "policy.layers.0.weight");
  EXPECT_EQ(named[0].tensor.shape(), (ag::Shape{128, 3}));
  EXPECT_EQ(named[6].tensor.shape(), (ag::Shape{2, 128}));
}

TEST(MAMLPolicy, LossTermsAreTheQueryLossAfterAndTheSupportLossBefore) {
  auto maml = tiny_maml(config_with(0.3, 4), 2);
  const core::Batch batch = make_batch(2, 7, 3, Dtype::Float64);  // 3 support + 4 query rows per task
  const core::LossTerms terms = maml->loss(batch);
  EXPECT_EQ(maml->support_per_task(), 3);
  ASSERT_EQ(terms.terms.size(), 2u);
  EXPECT_EQ(terms.terms[0].first, "query_bc");
  EXPECT_EQ(terms.terms[1].first, "support_bc");
  EXPECT_DOUBLE_EQ(terms.terms[0].second.item(), terms.total.item());
  // Before adaptation every task uses theta, so the support term is theta's BC loss on the support rows.
  EXPECT_NEAR(terms.terms[1].second.item(), maml->bc_loss(task_blocks(batch, 0, 3)).item(), 1e-12);
  // One inner step with this rate lowers the loss on the query rows in this case (the tasks' targets are smooth).
  EXPECT_LT(terms.total.item(), maml->bc_loss(task_blocks(batch, 3, 4)).item());
}

// Largest |analytic - central difference| over every parameter of the meta-loss, and the largest |numerical|.
struct FdComparison {
  double max_error = 0.0;
  double max_gradient = 0.0;
};

FdComparison compare_with_finite_differences(core::MAML& maml, const core::Batch& batch,
                                             const std::vector<Tensor>& analytic) {
  const std::vector<Tensor> params = maml.parameters();
  const double eps = 1e-6;
  FdComparison out;
  for (std::size_t k = 0; k < params.size(); ++k) {
    Tensor param = params[k];
    double* values = param.data<double>();
    for (std::int64_t e = 0; e < param.numel(); ++e) {
      const double original = values[e];
      values[e] = original + eps;
      const double plus = maml.loss(batch).total.item();
      values[e] = original - eps;
      const double minus = maml.loss(batch).total.item();
      values[e] = original;
      const double numerical = (plus - minus) / (2 * eps);
      out.max_error = std::max(out.max_error, std::abs(analytic[k].at(e) - numerical));
      out.max_gradient = std::max(out.max_gradient, std::abs(numerical));
    }
  }
  return out;
}

// Measured: max |analytic - central difference| 6.7e-11 (one inner step) and 5.6e-11 (two), for gradients up to
// 0.13 and 0.15.
TEST(MAMLPolicy, SecondOrderMetaGradientMatchesFiniteDifferences) {
  const core::Batch batch = make_batch(2, 7, 4, Dtype::Float64);
  for (int inner_steps : {1, 2}) {
    auto maml = tiny_maml(config_with(0.5, 4, /*first_order=*/false, inner_steps), 5);
    const std::vector<Tensor> params = maml->parameters();
    const auto r = ag::gradcheck(
        "MAML meta-loss", [&](const std::vector<Tensor>&) { return maml->loss(batch).total; }, params);
    EXPECT_TRUE(r.ok) << "inner_steps " << inner_steps << ": " << r.message;
    const std::vector<Tensor> analytic = ag::grad({maml->loss(batch).total}, params);
    const FdComparison fd = compare_with_finite_differences(*maml, batch, analytic);
    EXPECT_LT(fd.max_error, 1e-8) << "inner_steps " << inner_steps;
    EXPECT_GT(fd.max_gradient, 1e-2);
  }
}

TEST(MAMLPolicy, FirstOrderMetaGradientIsTheQueryGradientAtTheAdaptedParameters) {
  const core::Batch batch = make_batch(2, 7, 6, Dtype::Float64);
  auto first = tiny_maml(config_with(0.5, 4, /*first_order=*/true), 7);
  auto second = tiny_maml(config_with(0.5, 4, /*first_order=*/false), 7);
  const std::vector<Tensor> params = first->parameters();
  const std::vector<Tensor> fo = ag::grad({first->loss(batch).total}, params);
  const std::vector<Tensor> so = ag::grad({second->loss(batch).total}, second->parameters());
  // Both modes compute the same meta-loss value; only the gradient differs.
  EXPECT_NEAR(first->loss(batch).total.item(), second->loss(batch).total.item(), 1e-14);

  // FOMAML by hand: theta'_k = theta - a grad L_support_k(theta), then the mean over k of grad L_query_k(theta'_k).
  std::vector<Tensor> expected;
  for (const Tensor& p : params) expected.push_back(ag::zeros_like(p));
  for (int k = 0; k < 2; ++k) {
    core::Batch support = task_blocks(batch, 0, 3), query = task_blocks(batch, 3, 4);
    support = rows_of(support, {3 * k, 3 * k + 1, 3 * k + 2});
    query = rows_of(query, {4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3});
    auto learner = tiny_maml(config_with(0.5, 4), 7);
    const std::vector<Tensor> lp = learner->parameters();
    const auto g = ag::grad({learner->bc_loss(support)}, lp);
    {
      ag::NoGradGuard no_grad;
      for (std::size_t i = 0; i < lp.size(); ++i) {
        Tensor p = lp[i];
        p.copy_(lp[i] - 0.5 * g[i]);
      }
    }
    const auto gq = ag::grad({learner->bc_loss(query)}, lp);
    for (std::size_t i = 0; i < lp.size(); ++i) expected[i] = expected[i] + gq[i] * 0.5;
  }
  double fo_error = 0.0, second_order_effect = 0.0;
  for (std::size_t i = 0; i < params.size(); ++i) {
    fo_error = std::max(fo_error, max_abs_diff(fo[i], expected[i]));
    second_order_effect = std::max(second_order_effect, max_abs_diff(fo[i], so[i]));
  }
  EXPECT_LT(fo_error, 1e-12);
  // The Hessian term is visible at this inner rate (measured: up to 0.097 apart, for gradients up to 0.074):
  // first order is an approximation, not the gradient.
  EXPECT_GT(second_order_effect, 1e-3);
  const auto r = ag::gradcheck(
      "FOMAML", [&](const std::vector<Tensor>&) { return first->loss(batch).total; }, params);
  EXPECT_FALSE(r.ok);
}

// Meta-training on 16 fixed states per task (8 support, 8 query), default inner rate 0.01, 400 Adam steps at 3e-3.
// Measured at seed 8: second order 0.37 -> 7.1e-7 (theta alone on the query rows: 0.085), first order
// 0.37 -> 1.6e-3 (theta alone: 0.012); over five seeds the final loss stayed below 5e-3 in both modes, hence 0.03.
// (At inner rates 0.03 and 0.1 first-order MAML diverged on this problem while second order still fit it: the
// Hessian term it drops is large there.)
TEST(MAMLPolicy, MetaTrainingLowersTheQueryLossAfterAdaptation) {
  for (bool first_order : {false, true}) {
    ag::Generator gen(8);
    core::MAMLConfig config;
    config.query_per_task = 8;
    config.first_order = first_order;
    core::MAML maml(core::PolicyShape{3, 2, 2}, gen, config);
    const core::Batch batch = make_batch(2, 16, 9);
    const std::vector<double> losses = train(maml, batch, 400, 3e-3);
    EXPECT_GT(losses.front(), 0.2) << "first_order " << first_order;
    EXPECT_LT(losses.back(), 0.03) << "first_order " << first_order << ": " << losses.front() << " -> "
                                   << losses.back();
    // The adaptation does the work: theta alone is worse on the same query rows.
    EXPECT_LT(losses.back(), maml.bc_loss(task_blocks(batch, 8, 8)).item()) << "first_order " << first_order;
  }
}

// Task k's rows of a balanced batch, as an unbalanced batch.
core::Batch task_rows(const core::Batch& b, std::int64_t task) {
  std::vector<std::int64_t> rows;
  for (std::int64_t i = 0; i < b.per_task; ++i) rows.push_back(task * b.per_task + i);
  return rows_of(b, rows);
}

TEST(MAMLPolicy, ActUsesEachRowsTaskAfterAdaptation) {
  auto maml = tiny_maml(config_with(0.2, 4), 10, {8});
  const core::Batch batch = make_batch(2, 10, 11, Dtype::Float64);
  const core::Batch mixed = rows_of(batch, shuffled_rows(20, 12));
  const std::vector<std::int64_t> all0(20, 0), all1(20, 1);
  // Before adaptation the task is ignored.
  const Tensor theta_out = maml->act(mixed.observations, mixed.tasks);
  EXPECT_EQ(max_abs_diff(theta_out, maml->act(mixed.observations, all0)), 0.0);
  const std::vector<core::Batch> train_batches{task_rows(batch, 0), task_rows(batch, 1)};
  std::vector<double> before;
  for (const auto& t : train_batches) before.push_back(maml->bc_loss(t).item());
  const Tensor theta_before = maml->parameters().front().detach().clone();

  // No validation rows: every fine-tuning step is kept.
  const core::Batch empty = rows_of(batch, {});
  maml->adapt(train_batches, {empty, empty});
  ASSERT_TRUE(maml->adapted());
  EXPECT_EQ(maml->adapted_steps(), (std::vector<int>{10, 10}));
  EXPECT_TRUE(std::isnan(maml->adapted_validation_loss()[0]));
  // theta itself is untouched.
  EXPECT_EQ(max_abs_diff(maml->parameters().front(), theta_before), 0.0);

  const Tensor acted = maml->act(mixed.observations, mixed.tasks);
  const Tensor as0 = maml->act(mixed.observations, all0);
  const Tensor as1 = maml->act(mixed.observations, all1);
  EXPECT_GT(max_abs_diff(as0, as1), 1e-4);
  EXPECT_GT(max_abs_diff(as0, theta_out), 1e-4);
  for (std::int64_t j = 0; j < 20; ++j) {
    const Tensor& own = mixed.tasks[static_cast<std::size_t>(j)] == 0 ? as0 : as1;
    EXPECT_LT(max_abs_diff(ag::narrow(acted, 0, j, 1), ag::narrow(own, 0, j, 1)), 1e-12) << "row " << j;
  }
  for (std::size_t k = 0; k < 2; ++k) EXPECT_LT(maml->bc_loss(train_batches[k]).item(), before[k]) << "task " << k;

  // clone() carries the adaptation; clear_adaptation() returns to theta.
  auto copy = maps::nn::clone(maml);
  EXPECT_EQ(max_abs_diff(copy->act(mixed.observations, mixed.tasks), acted), 0.0);
  maml->clear_adaptation();
  EXPECT_FALSE(maml->adapted());
  EXPECT_EQ(max_abs_diff(maml->act(mixed.observations, mixed.tasks), theta_out), 0.0);
  // Converting the module keeps the adaptation usable.
  copy->to(Dtype::Float32);
  EXPECT_LT(max_abs_diff(copy->act(mixed.observations.to(Dtype::Float32), mixed.tasks), acted.to(Dtype::Float32)),
            1e-5);
}

// The chosen step count is the validation argmin over 0..finetune_steps, so it can only match or beat theta.
TEST(MAMLPolicy, AdaptNeverRaisesTheValidationLoss) {
  int some_steps = 0, zero_steps = 0;
  for (std::uint64_t seed = 20; seed < 26; ++seed) {
    for (bool adversarial : {false, true}) {
      auto maml = tiny_maml(config_with(0.3, 4), seed, {8});
      const core::Batch batch = make_batch(2, 12, seed + 100, Dtype::Float64);
      const core::Batch held_out = make_batch(2, 12, seed + 200, Dtype::Float64);
      std::vector<core::Batch> train, valid;
      for (std::int64_t k = 0; k < 2; ++k) {
        train.push_back(task_rows(batch, k));
        // Adversarial: validation states labelled with the other task's actions.
        core::Batch v = task_rows(held_out, adversarial ? 1 - k : k);
        v.tasks.assign(v.tasks.size(), k);
        valid.push_back(v);
      }
      std::vector<double> unadapted;
      for (const auto& v : valid) unadapted.push_back(maml->bc_loss(v).item());
      maml->adapt(train, valid);
      for (std::size_t k = 0; k < 2; ++k) {
        const int steps = maml->adapted_steps()[k];
        EXPECT_GE(steps, 0);
        EXPECT_LE(steps, 10);
        (steps > 0 ? some_steps : zero_steps)++;
        EXPECT_NEAR(maml->unadapted_validation_loss()[k], unadapted[k], 1e-12);
        // The stored parameters are the chosen ones: act() reproduces the recorded validation loss.
        const double adapted = maml->bc_loss(valid[k]).item();
        EXPECT_NEAR(adapted, maml->adapted_validation_loss()[k], 1e-12);
        EXPECT_LE(adapted, unadapted[k]) << "seed " << seed << " task " << k << " adversarial " << adversarial;
        if (steps == 0) {
          EXPECT_EQ(adapted, unadapted[k]);
        }
      }
    }
  }
  // Both outcomes occur, so the comparison above is not vacuous.
  EXPECT_GT(some_steps, 0);
  EXPECT_GT(zero_steps, 0);
}

TEST(MAMLPolicy, ZeroFinetuneStepsKeepsTheta) {
  core::MAMLConfig config = config_with(0.3, 4);
  config.finetune_steps = 0;
  auto maml = tiny_maml(config, 30);
  const core::Batch batch = make_batch(2, 5, 31, Dtype::Float64);
  const Tensor before = maml->act(batch.observations, batch.tasks);
  maml->adapt({task_rows(batch, 0), task_rows(batch, 1)}, {task_rows(batch, 0), task_rows(batch, 1)});
  EXPECT_EQ(maml->adapted_steps(), (std::vector<int>{0, 0}));
  EXPECT_EQ(max_abs_diff(maml->act(batch.observations, batch.tasks), before), 0.0);
}

// A demo file held in memory: 2 tasks, 3 demos each (2 train, 1 valid) of 20 steps, actions from target().
maps::envs::DemoFile tiny_demo_file() {
  maps::envs::DemoFile file;
  file.task_set = "toy";
  file.task_names = {"toy/a", "toy/b"};
  ag::Generator gen(40);
  for (int i = 0; i < 6; ++i) {
    maps::envs::Demonstration d;
    d.task_index = i / 3;
    d.task = file.task_names[static_cast<std::size_t>(d.task_index)];
    d.seed = static_cast<std::uint64_t>(i);
    d.obs = Eigen::MatrixXd(20, 3);
    d.actions = Eigen::MatrixXd(20, 2);
    for (int t = 0; t < 20; ++t) {
      for (int c = 0; c < 3; ++c) d.obs(t, c) = gen.uniform(-1.0, 1.0);
      const double s[3] = {d.obs(t, 0), d.obs(t, 1), d.obs(t, 2)};
      const std::vector<double> a = target(d.task_index, s);
      d.actions(t, 0) = a[0];
      d.actions(t, 1) = a[1];
    }
    d.rewards = Eigen::VectorXd::Zero(20);
    d.dones.assign(20, 0);
    d.dones.back() = 1;
    (i % 3 == 2 ? file.valid : file.train).push_back(i);
    file.demos.push_back(d);
  }
  return file;
}

TEST(MAMLPolicy, PrepareForEvaluationFineTunesOnTheDataset) {
  const core::DemoDataset data(tiny_demo_file(), core::DataConfig{});
  auto maml = tiny_maml(config_with(0.3, 4), 41, {8});
  EXPECT_EQ(maml->batch_per_task(16), 20);
  maml->prepare_for_evaluation(data);
  ASSERT_TRUE(maml->adapted());
  const std::vector<int> steps = maml->adapted_steps();
  for (int k = 0; k < 2; ++k) {
    const core::Batch valid = data.task_validation_batch(k, Dtype::Float64);
    EXPECT_NEAR(maml->bc_loss(valid).item(), maml->adapted_validation_loss()[static_cast<std::size_t>(k)], 1e-12);
    EXPECT_LE(maml->adapted_validation_loss()[static_cast<std::size_t>(k)],
              maml->unadapted_validation_loss()[static_cast<std::size_t>(k)]);
  }
  // Deterministic for the config's seed.
  auto again = tiny_maml(config_with(0.3, 4), 41, {8});
  again->batch_per_task(16);
  again->prepare_for_evaluation(data);
  EXPECT_EQ(again->adapted_steps(), steps);
  EXPECT_EQ(again->adapted_validation_loss(), maml->adapted_validation_loss());
}

TEST(MAMLPolicy, BadInputErrorsNameTheClass) {
  auto maml = tiny_maml(config_with(0.3, 4), 50);
  const core::Batch batch = make_batch(2, 6, 51, Dtype::Float64);
  core::Batch unbalanced = batch;
  unbalanced.per_task = 0;
  EXPECT_THAT(error_of([&] { maml->loss(unbalanced); }),
              AllOf(HasSubstr("MAML::loss"), HasSubstr("expected a balanced batch"), HasSubstr("per_task 0")));
  const core::Batch too_small = make_batch(2, 4, 52, Dtype::Float64);
  EXPECT_THAT(error_of([&] { maml->loss(too_small); }),
              AllOf(HasSubstr("MAML::loss"), HasSubstr("query_per_task (4)"), HasSubstr("got per_task 4")));
  EXPECT_THAT(error_of([&] { maml->batch_per_task(0); }), HasSubstr("MAML::batch_per_task"));
  EXPECT_THAT(error_of([&] {
                maml->act(ag::zeros({2, 2}, Dtype::Float64), {0, 1});
              }),
              AllOf(HasSubstr("MAML::act"), HasSubstr("expected observations [n, 3]")));
  EXPECT_THAT(error_of([&] {
                maml->act(ag::zeros({2, 3}, Dtype::Float64), {0, 2});
              }),
              AllOf(HasSubstr("MAML::act"), HasSubstr("task 2 at row 1")));
  EXPECT_THAT(error_of([&] { maml->adapt({task_rows(batch, 0)}, {task_rows(batch, 0)}); }),
              AllOf(HasSubstr("MAML::adapt"), HasSubstr("one training and one validation batch per task (2)")));
  EXPECT_THAT(error_of([&] {
                maml->adapt({task_rows(batch, 0), task_rows(batch, 0)}, {task_rows(batch, 0), task_rows(batch, 1)});
              }),
              AllOf(HasSubstr("MAML::adapt (training)"), HasSubstr("must hold only task 1's rows")));
  EXPECT_THAT(error_of([&] {
                maml->adapt({rows_of(batch, {}), task_rows(batch, 1)}, {task_rows(batch, 0), task_rows(batch, 1)});
              }),
              AllOf(HasSubstr("MAML::adapt"), HasSubstr("training batch of task 0 is empty")));
  ag::Generator gen(53);
  core::MAMLConfig bad;
  bad.inner_steps = 0;
  EXPECT_THAT(error_of([&] {
                core::MAML(core::PolicyShape{3, 2, 2}, gen, bad);
              }),
              AllOf(HasSubstr("MAML: expected"), HasSubstr("inner_steps >= 1")));
  EXPECT_THAT(error_of([&] { core::MAML(core::PolicyShape{0, 2, 2}, gen); }), HasSubstr("MAML: observation_size"));
  const maps::envs::DemoFile file = tiny_demo_file();
  const core::DemoDataset data(file, core::DataConfig{});
  ag::Generator gen3(54);
  core::MAML three(core::PolicyShape{3, 2, 3}, gen3);
  EXPECT_THAT(error_of([&] { three.prepare_for_evaluation(data); }),
              AllOf(HasSubstr("MAML::prepare_for_evaluation"), HasSubstr("dataset of 3 tasks, got 2")));
}

}  // namespace
}  // namespace baselinetest
