#include "maps/evaluation/evaluator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "envs/task_expert.h"
#include "envs/task_sets.h"
#include "nn/mlp.h"
#include "tests/common/error_of.h"

namespace maps::core {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// ----- policies -----

// A policy given as a function, for tests that need a particular action rule.
class FnPolicy : public Policy {
 public:
  using ActFn = std::function<ag::Tensor(const ag::Tensor&, const std::vector<std::int64_t>&)>;
  FnPolicy(PolicyShape shape, ActFn act) : Policy("FnPolicy", shape), act_(std::move(act)) {}
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    return act_(observations, tasks);
  }
  LossTerms loss(const Batch&) override { throw std::logic_error("FnPolicy is not trainable"); }

 protected:
  std::shared_ptr<nn::Module> shallow_copy() const override { return std::make_shared<FnPolicy>(*this); }

 private:
  ActFn act_;
};

// Each row's action computed on its own in a fixed order, so a row's action cannot depend on what else is in the
// batch: batched and one-at-a-time evaluations must then agree bit for bit.
FnPolicy rowwise_linear_policy(PolicyShape shape) {
  return FnPolicy(shape, [shape](const ag::Tensor& x, const std::vector<std::int64_t>& tasks) {
    const ag::RowMatrixD obs = ag::to_eigen_double(x);
    ag::RowMatrixD actions(obs.rows(), shape.action_size);
    for (Eigen::Index i = 0; i < obs.rows(); ++i)
      for (Eigen::Index j = 0; j < actions.cols(); ++j) {
        double z = 0.2 * static_cast<double>(tasks[static_cast<std::size_t>(i)]) - 0.1;
        for (Eigen::Index k = 0; k < obs.cols(); ++k) z += 0.4 * std::sin(1.0 + 3.0 * j + 0.7 * k) * obs(i, k);
        actions(i, j) = std::tanh(z);
      }
    return ag::from_eigen(actions).to(x.dtype());
  });
}

// The committed expert of tasks[id] on the un-standardised observation (row by row); tasks whose name is in
// `constant` get that constant action instead.
FnPolicy expert_policy(PolicyShape shape, const std::vector<std::string>& tasks, const Standardizer& standardizer,
                       const std::map<std::string, double>& constant = {}) {
  std::vector<std::function<Eigen::VectorXd(const Eigen::VectorXd&)>> rules;
  for (const std::string& task : tasks) {
    if (constant.count(task) != 0) {
      const double value = constant.at(task);
      const auto size = shape.action_size;
      rules.push_back([value, size](const Eigen::VectorXd&) { return Eigen::VectorXd::Constant(size, value); });
    } else {
      rules.push_back(envs::load_task_expert(task).mean_action);
    }
  }
  return FnPolicy(shape, [rules, standardizer](const ag::Tensor& x, const std::vector<std::int64_t>& ids) {
    const ag::RowMatrixD obs = ag::to_eigen_double(x);
    ag::RowMatrixD actions;
    for (Eigen::Index i = 0; i < obs.rows(); ++i) {
      const Eigen::VectorXd raw = obs.row(i).transpose().cwiseProduct(standardizer.std) + standardizer.mean;
      const Eigen::VectorXd a = rules[static_cast<std::size_t>(ids[static_cast<std::size_t>(i)])](raw);
      if (i == 0) actions.resize(obs.rows(), a.size());
      actions.row(i) = a.transpose();
    }
    return ag::from_eigen(actions).to(x.dtype());
  });
}

// A tanh MLP on [observation, one-hot task], built through the autograd engine like the real policies.
class MlpPolicy : public Policy {
 public:
  MlpPolicy(PolicyShape shape, std::int64_t hidden, int layers, std::uint64_t seed) : Policy("MlpPolicy", shape) {
    ag::Generator gen(seed);
    std::vector<std::int64_t> sizes{shape.observation_size + shape.num_tasks};
    for (int l = 0; l < layers; ++l) sizes.push_back(hidden);
    sizes.push_back(shape.action_size);
    mlp_ = register_module("mlp", std::make_shared<nn::MLP>(sizes, "tanh", gen));
  }
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    const ag::Tensor input = ag::concat({observations, ag::one_hot(tasks, shape().num_tasks, observations.dtype())}, 1);
    return child_at<nn::MLP>(mlp_).forward(input);
  }
  LossTerms loss(const Batch&) override { throw std::logic_error("MlpPolicy is not trainable"); }

 protected:
  std::shared_ptr<nn::Module> shallow_copy() const override { return std::make_shared<MlpPolicy>(*this); }

 private:
  std::size_t mlp_ = 0;
};

// ----- a toy env whose episodes end at different steps -----

// obs (x, v, t); the first action entry pushes v. Episodes terminate after 2 + seed % 7 steps (so the batch
// shrinks unevenly); reward x * a0 - 0.1 a1^2 makes returns of both signs; success when x > 0.3.
class ToyEnv : public envs::Env {
 public:
  explicit ToyEnv(std::string task, double drift) : drift_(drift) {
    spec_ = envs::unit_box_spec(std::move(task), 0, 3, 2, 100);
  }
  const envs::EnvSpec& spec() const override { return spec_; }
  Eigen::VectorXd reset(std::uint64_t seed) override {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    x_ = u(rng);
    v_ = u(rng);
    t_ = 0;
    length_ = 2 + static_cast<int>(seed % 7);
    return obs();
  }
  envs::StepResult step(const Eigen::VectorXd& action) override {
    if (t_ >= length_) throw std::logic_error("ToyEnv: step after the end");
    v_ = 0.9 * v_ + 0.1 * action[0] + drift_;
    x_ += v_;
    ++t_;
    envs::StepResult r;
    r.observation = obs();
    r.reward = x_ * action[0] - 0.1 * action[1] * action[1];
    r.terminated = t_ >= length_;
    r.success = x_ > 0.3;
    return r;
  }

 private:
  Eigen::VectorXd obs() const { return Eigen::Vector3d(x_, v_, 0.1 * t_); }
  envs::EnvSpec spec_;
  double drift_;
  double x_ = 0.0, v_ = 0.0;
  int t_ = 0, length_ = 0;
};

std::unique_ptr<envs::Env> make_toy_env(const std::string& task) {
  return std::make_unique<ToyEnv>(task, task == "toy/b" ? 0.05 : -0.02);
}

Standardizer make_standardizer(std::int64_t size) {
  Standardizer s;
  s.mean = Eigen::VectorXd::LinSpaced(size, -0.3, 0.4);
  s.std = Eigen::VectorXd::LinSpaced(size, 0.5, 2.0);
  return s;
}

Standardizer identity_standardizer(std::int64_t size) {
  Standardizer s;
  s.mean = Eigen::VectorXd::Zero(size);
  s.std = Eigen::VectorXd::Ones(size);
  return s;
}

PolicyShape shape_of(const std::string& task, std::int64_t num_tasks) {
  const auto env = envs::make_env(task);
  return {env->spec().observation_size, env->spec().action_size, num_tasks};
}

// The reference: each episode on its own, the policy called with one row per step.
struct AloneResult {
  std::vector<double> returns;
  std::vector<bool> successes;
  std::vector<bool> final_successes;  // the success test at the episode's last step
  Eigen::VectorXd usage_sum;
  std::int64_t usage_rows = 0;
};

AloneResult run_alone(const EnvFactory& make_env, Policy& policy, const Standardizer& standardizer,
                      const std::string& task, std::int64_t task_id, const EvalConfig& config,
                      const ModuleUsageFn* usage = nullptr) {
  ag::NoGradGuard no_grad;
  AloneResult out;
  for (int e = 0; e < config.episodes; ++e) {
    auto env = make_env(task);
    Eigen::VectorXd obs = env->reset(config.first_seed + static_cast<std::uint64_t>(e));
    double total = 0.0;
    bool success = false, final_success = false;
    for (bool done = false; !done;) {
      const Eigen::MatrixXd row = obs.transpose();
      const ag::Tensor x = standardizer.apply(row, config.dtype);
      const Eigen::VectorXd action = ag::to_eigen_double(policy.act(x, {task_id})).row(0).transpose();
      if (usage != nullptr) {
        const Eigen::VectorXd u = ag::to_eigen_double((*usage)(x, {task_id})).row(0).transpose();
        if (out.usage_sum.size() == 0) out.usage_sum = Eigen::VectorXd::Zero(u.size());
        out.usage_sum += u;
        ++out.usage_rows;
      }
      const envs::StepResult r = env->step(action);
      total += r.reward;
      success = success || r.success;
      final_success = r.success;
      obs = r.observation;
      done = r.done();
    }
    out.returns.push_back(total);
    out.successes.push_back(success);
    out.final_successes.push_back(final_success);
  }
  return out;
}

const EnvFactory kRegistry = [](const std::string& task) { return envs::make_env(task); };

// ----- (1) batched == alone -----

TEST(Evaluator, BatchedStepsMatchEpisodesSteppedAloneWhenEpisodesEndAtDifferentSteps) {
  const std::vector<std::string> tasks{"toy/a", "toy/b"};
  FnPolicy policy = rowwise_linear_policy({3, 2, 2});
  const Standardizer standardizer = make_standardizer(3);
  EvalConfig config;
  config.episodes = 13;
  config.first_seed = 5;
  config.threads = 1;
  // 0: one env per episode; 4 and 1: that many envs, each starting the next pending episode when its own ends.
  for (int max_envs : {0, 4, 1}) {
    config.max_envs_per_task = max_envs;
    const EvaluationResult result = evaluate_with_envs(make_toy_env, policy, standardizer, tasks, {}, config);
    ASSERT_EQ(result.tasks.size(), 2u);
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      const AloneResult alone =
          run_alone(make_toy_env, policy, standardizer, tasks[i], static_cast<std::int64_t>(i), config);
      EXPECT_EQ(result.tasks[i].task, tasks[i]);
      EXPECT_EQ(result.tasks[i].episodes, 13);
      EXPECT_EQ(result.tasks[i].returns, alone.returns) << tasks[i] << ", max_envs_per_task " << max_envs;
      EXPECT_EQ(result.tasks[i].successes, alone.successes) << tasks[i] << ", max_envs_per_task " << max_envs;
      EXPECT_EQ(result.tasks[i].final_successes, alone.final_successes) << tasks[i] << ", max_envs " << max_envs;
      const auto at_end = std::count(alone.final_successes.begin(), alone.final_successes.end(), true);
      EXPECT_DOUBLE_EQ(result.tasks[i].final_success_rate, static_cast<double>(at_end) / 13.0);
    }
  }
}

TEST(Evaluator, BatchedStepsMatchEpisodesSteppedAloneOnRealTasks) {
  for (const std::string task : {"gravity/1.0", "mt10/reach"}) {
    // Task id 1 of 2, so the id the policy sees is the position in the list, not the registry index.
    const bool mt10 = task == "mt10/reach";
    const std::vector<std::string> tasks{mt10 ? "mt10/push" : "gravity/0.5", task};
    const PolicyShape shape = shape_of(task, 2);
    const Standardizer standardizer = make_standardizer(shape.observation_size);
    // MT10 rewards only success steps, so there the scripted expert (id 1; id 0 holds still) gives returns that
    // tell episodes apart.
    FnPolicy policy =
        mt10 ? expert_policy(shape, tasks, standardizer, {{"mt10/push", 0.0}}) : rowwise_linear_policy(shape);
    EvalConfig config;
    config.episodes = 3;
    const EvaluationResult result = evaluate(policy, standardizer, {task}, {}, config);
    const AloneResult alone = run_alone(kRegistry, policy, standardizer, task, 0, config);
    EXPECT_EQ(result.tasks[0].returns, alone.returns) << task;
    EXPECT_EQ(result.tasks[0].successes, alone.successes) << task;

    const AloneResult alone1 = run_alone(kRegistry, policy, standardizer, task, 1, config);
    // An env reused for a later episode (max_envs_per_task < episodes) must behave as a fresh one.
    for (int max_envs : {0, 2}) {
      config.max_envs_per_task = max_envs;
      const EvaluationResult second = evaluate(policy, standardizer, tasks, {}, config);
      EXPECT_EQ(second.tasks[1].returns, alone1.returns) << task << ", max_envs_per_task " << max_envs;
      EXPECT_EQ(second.tasks[1].successes, alone1.successes) << task << ", max_envs_per_task " << max_envs;
      EXPECT_NE(second.tasks[1].returns, result.tasks[0].returns) << task << ": the task id should change actions";
      EXPECT_NE(second.tasks[1].returns[0], second.tasks[1].returns[1]) << task;
    }
  }
}

// ----- (2) repeatable, independent of threads -----

TEST(Evaluator, SameConfigGivesIdenticalResultsWithOneOrTwoThreads) {
  const std::vector<std::string> tasks{"gravity/0.5", "gravity/1.0", "gravity/1.5"};
  MlpPolicy policy(shape_of("gravity/1.0", 3), 32, 3, 7);
  const Standardizer standardizer = make_standardizer(policy.shape().observation_size);
  const ModuleUsageFn usage = [](const ag::Tensor& x, const std::vector<std::int64_t>&) {
    return ag::softmax(ag::narrow(x, 1, 0, 4), 1);
  };
  EvalConfig config;
  config.episodes = 2;
  config.threads = 1;
  const EvaluationResult a = evaluate(policy, standardizer, tasks, {}, config, &usage);
  const EvaluationResult b = evaluate(policy, standardizer, tasks, {}, config, &usage);
  config.threads = 2;
  const EvaluationResult c = evaluate(policy, standardizer, tasks, {}, config, &usage);
  ASSERT_EQ(c.tasks.size(), 3u);
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    EXPECT_EQ(a.tasks[i].task, tasks[i]);
    EXPECT_EQ(a.tasks[i].returns, b.tasks[i].returns);
    EXPECT_EQ(a.tasks[i].returns, c.tasks[i].returns) << tasks[i];
    EXPECT_EQ(a.tasks[i].module_usage, c.tasks[i].module_usage) << tasks[i];
    EXPECT_EQ(a.tasks[i].score, c.tasks[i].score);
  }
  EXPECT_NE(a.tasks[0].returns, a.tasks[1].returns);
  EXPECT_NE(a.tasks[0].returns[0], a.tasks[0].returns[1]) << "different seeds should give different episodes";
}

TEST(Evaluator, ThreadsBeyondTheTaskCountOnlyHelpStepAndGiveIdenticalResults) {
  // Episodes of unequal length, so the shared-out steps cover a shrinking (or refilled) batch. The MLP rounds a row
  // differently in batches of other sizes, so equal returns also show the batches are the same.
  MlpPolicy policy({3, 2, 2}, 16, 2, 5);
  const Standardizer standardizer = make_standardizer(3);
  for (int max_envs : {0, 7}) {
    EvalConfig config;
    config.episodes = 40;
    config.max_envs_per_task = max_envs;
    config.threads = 1;
    const EvaluationResult one = evaluate_with_envs(make_toy_env, policy, standardizer, {"toy/a", "toy/b"}, {}, config);
    for (int threads : {2, 3, 5}) {
      config.threads = threads;
      const EvaluationResult many =
          evaluate_with_envs(make_toy_env, policy, standardizer, {"toy/a", "toy/b"}, {}, config);
      for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(many.tasks[i].returns, one.tasks[i].returns) << threads << " threads, max_envs " << max_envs;
        EXPECT_EQ(many.tasks[i].successes, one.tasks[i].successes) << threads << " threads, max_envs " << max_envs;
      }
    }
  }
  // One real task on two threads: the second thread only steps envs.
  MlpPolicy mlp(shape_of("gravity/1.0", 1), 16, 2, 3);
  const Standardizer cheetah = make_standardizer(17);
  EvalConfig real;
  real.episodes = 4;
  real.threads = 1;
  const EvaluationResult alone = evaluate(mlp, cheetah, {"gravity/1.0"}, {}, real);
  real.threads = 2;
  const EvaluationResult helped = evaluate(mlp, cheetah, {"gravity/1.0"}, {}, real);
  EXPECT_EQ(helped.tasks[0].returns, alone.tasks[0].returns);
}

// ----- (3) scores -----

TEST(Evaluator, ReturnScoreIsFlooredPerEpisodeAndNotCapped) {
  // Toy returns have both signs: the floor applies per episode, before the mean.
  FnPolicy policy = rowwise_linear_policy({3, 2, 1});
  EvalConfig config;
  config.episodes = 20;
  const EvaluationResult result =
      evaluate_with_envs(make_toy_env, policy, make_standardizer(3), {"toy/a"}, {0.25}, config);
  const TaskEvaluation& t = result.tasks[0];
  int negative = 0;
  std::vector<double> scores;
  for (double r : t.returns) {
    negative += r < 0.0 ? 1 : 0;
    scores.push_back(std::max(0.0, r / 0.25));
  }
  ASSERT_GT(negative, 0);
  ASSERT_LT(negative, 20);
  const double mean = std::accumulate(scores.begin(), scores.end(), 0.0) / 20.0;
  double ss = 0.0;
  for (double s : scores) ss += (s - mean) * (s - mean);
  EXPECT_NEAR(t.score, mean, 1e-12);
  EXPECT_GT(t.score, std::max(0.0, t.return_mean / 0.25));  // flooring episodes is not flooring the mean
  EXPECT_NEAR(t.score_std_error, std::sqrt(ss / 19.0 / 20.0), 1e-12);
  EXPECT_NEAR(t.score_ci95(), 2.0930240544 * t.score_std_error, 1e-9);  // Student's t, 19 degrees of freedom
  EXPECT_DOUBLE_EQ(result.mean_score, t.score);
}

TEST(Evaluator, TQuantilesAreStudentsNotTheNormals) {
  EXPECT_NEAR(t_quantile_95(1), 12.7062047362, 1e-9);
  EXPECT_NEAR(t_quantile_95(4), 2.7764451052, 1e-9);
  EXPECT_NEAR(t_quantile_95(99), 1.9842169516, 1e-9);
  EXPECT_NEAR(t_quantile_95(1000000), 1.959966, 1e-6);
  EXPECT_THROW(t_quantile_95(0), std::invalid_argument);
}

TEST(Evaluator, ATaskEvaluatedAloneKeepsItsTaskId) {
  FnPolicy policy = rowwise_linear_policy({3, 2, 2});
  const Standardizer standardizer = make_standardizer(3);
  EvalConfig config;
  config.episodes = 5;
  config.threads = 1;
  const EvaluationResult both = evaluate_with_envs(make_toy_env, policy, standardizer, {"toy/a", "toy/b"}, {}, config);
  config.task_ids = {1};
  const EvaluationResult alone = evaluate_with_envs(make_toy_env, policy, standardizer, {"toy/b"}, {}, config);
  ASSERT_EQ(alone.tasks.size(), 1u);
  EXPECT_EQ(alone.tasks[0].returns, both.tasks[1].returns);
  config.task_ids = {2};
  EXPECT_THAT([&] { evaluate_with_envs(make_toy_env, policy, standardizer, {"toy/b"}, {}, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("task id 2")));
  config.task_ids = {0, 1};
  EXPECT_THAT([&] { evaluate_with_envs(make_toy_env, policy, standardizer, {"toy/b"}, {}, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("2 task ids for 1 tasks")));
}

TEST(Evaluator, HalfCheetahScoreIsReturnOverExpertReturn) {
  // gravity/1.0 run by its expert (about 5000) normalised by 2500: a score near 2, not capped at 1. gravity/1.5
  // held at a constant action pays control cost every step: negative returns, score exactly 0.
  const std::vector<std::string> tasks{"gravity/1.0", "gravity/1.5"};
  const Standardizer standardizer = make_standardizer(17);
  FnPolicy policy = expert_policy(shape_of("gravity/1.0", 2), tasks, standardizer, {{"gravity/1.5", 0.8}});
  EvalConfig config;
  config.episodes = 3;
  config.dtype = ag::Dtype::Float64;
  const EvaluationResult result = evaluate(policy, standardizer, tasks, {2500.0, 1000.0}, config);
  const TaskEvaluation& good = result.tasks[0];
  const TaskEvaluation& bad = result.tasks[1];
  EXPECT_GT(good.return_mean, 4000.0);
  EXPECT_NEAR(good.score, good.return_mean / 2500.0, 1e-12);
  EXPECT_GT(good.score, 1.5);
  double ss = 0.0;
  for (double r : good.returns) ss += (r / 2500.0 - good.score) * (r / 2500.0 - good.score);
  EXPECT_NEAR(good.score_std_error, std::sqrt(ss / 2.0 / 3.0), 1e-12);
  double return_ss = 0.0;
  for (double r : good.returns) return_ss += (r - good.return_mean) * (r - good.return_mean);
  EXPECT_NEAR(good.return_std, std::sqrt(return_ss / 3.0), 1e-9);
  EXPECT_LT(bad.return_mean, 0.0);
  EXPECT_EQ(bad.score, 0.0);
  EXPECT_EQ(bad.score_std_error, 0.0);
  EXPECT_NEAR(result.mean_score, good.score / 2.0, 1e-12);
}

TEST(Evaluator, ReportsTheReturnWithGymsControlCostOnTheUnclippedAction) {
  // A constant action of 2 on each of the 6 joints: Gym would charge 0.1 * 6 * (4 - 1) = 1.8 more per step.
  const std::vector<std::string> tasks{"gravity/1.5"};
  const Standardizer standardizer = make_standardizer(17);
  FnPolicy policy = expert_policy(shape_of("gravity/1.0", 1), tasks, standardizer, {{"gravity/1.5", 2.0}});
  EvalConfig config;
  config.episodes = 2;
  config.dtype = ag::Dtype::Float64;
  const TaskEvaluation t = evaluate(policy, standardizer, tasks, {1000.0}, config).tasks[0];
  EXPECT_NEAR(t.return_mean - t.return_mean_unclipped_cost, 1.8 * 1000, 1e-6);
}

TEST(Evaluator, Mt10ScoreIsSuccessRate) {
  // mt10/reach run by its scripted expert succeeds; mt10/push with a zero action never does.
  const std::vector<std::string> tasks{"mt10/reach", "mt10/push"};
  const PolicyShape shape = shape_of("mt10/reach", 2);
  const Standardizer standardizer = identity_standardizer(shape.observation_size);
  FnPolicy policy = expert_policy(shape, tasks, standardizer, {{"mt10/push", 0.0}});
  EvalConfig config;
  config.episodes = 4;
  config.dtype = ag::Dtype::Float64;
  const EvaluationResult result = evaluate(policy, standardizer, tasks, {}, config);
  const EvaluationResult nan_given = evaluate(policy, standardizer, tasks, {std::nan(""), std::nan("")}, config);
  for (std::size_t i = 0; i < 2; ++i) {
    const TaskEvaluation& t = result.tasks[i];
    const auto successes = std::count(t.successes.begin(), t.successes.end(), true);
    EXPECT_DOUBLE_EQ(t.success_rate, successes / 4.0);
    EXPECT_EQ(t.score, t.success_rate);
    EXPECT_NEAR(t.score_std_error, std::sqrt(t.score * (1.0 - t.score) / 3.0), 1e-12);
    EXPECT_EQ(nan_given.tasks[i].score, t.score);
  }
  EXPECT_GE(result.tasks[0].success_rate, 0.75);
  EXPECT_EQ(result.tasks[1].success_rate, 0.0);
  EXPECT_NE(result.tasks[0].return_mean, 0.0);  // returns are still reported
}

// ----- (4) module usage -----

TEST(Evaluator, ModuleUsageIsTheMeanScoreOverEveryVisitedState) {
  // Scores (x0, 1, task): the mean of x0 weights each state, so long episodes count more than short ones.
  const std::vector<std::string> tasks{"toy/a", "toy/b"};
  FnPolicy policy = rowwise_linear_policy({3, 2, 2});
  const Standardizer standardizer = make_standardizer(3);
  const ModuleUsageFn usage = [](const ag::Tensor& x, const std::vector<std::int64_t>& ids) {
    const ag::RowMatrixD obs = ag::to_eigen_double(x);
    ag::RowMatrixD scores(obs.rows(), 3);
    for (Eigen::Index i = 0; i < obs.rows(); ++i)
      scores.row(i) << obs(i, 0), 1.0, static_cast<double>(ids[static_cast<std::size_t>(i)]);
    return ag::from_eigen(scores).to(x.dtype());
  };
  EvalConfig config;
  config.episodes = 11;
  config.threads = 2;
  config.dtype = ag::Dtype::Float64;
  const EvaluationResult result = evaluate_with_envs(make_toy_env, policy, standardizer, tasks, {}, config, &usage);
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const AloneResult alone =
        run_alone(make_toy_env, policy, standardizer, tasks[i], static_cast<std::int64_t>(i), config, &usage);
    const Eigen::VectorXd expected = alone.usage_sum / static_cast<double>(alone.usage_rows);
    const Eigen::VectorXd& got = result.tasks[i].module_usage;
    ASSERT_EQ(got.size(), 3);
    EXPECT_NEAR(got[0], expected[0], 1e-12);
    EXPECT_EQ(got[1], 1.0);
    EXPECT_EQ(got[2], static_cast<double>(i));
    // Unequal episode lengths: the state-weighted mean differs from the mean of the per-episode means.
    EXPECT_GT(alone.usage_rows, 2 * 11);
  }
  const EvaluationResult without = evaluate_with_envs(make_toy_env, policy, standardizer, tasks, {}, config);
  EXPECT_EQ(without.tasks[0].module_usage.size(), 0);
}

TEST(Evaluator, SelectorEntropyAndTopScoreTellRoutingPerStateFromMixing) {
  // Task a: each state picks one module, alternating with the sign of x0 (its mean usage can still look spread);
  // task b: every state mixes two modules equally.
  const std::vector<std::string> tasks{"toy/a", "toy/b"};
  FnPolicy policy = rowwise_linear_policy({3, 2, 2});
  const Standardizer standardizer = make_standardizer(3);
  const ModuleUsageFn usage = [](const ag::Tensor& x, const std::vector<std::int64_t>& ids) {
    const ag::RowMatrixD obs = ag::to_eigen_double(x);
    ag::RowMatrixD scores(obs.rows(), 2);
    for (Eigen::Index i = 0; i < obs.rows(); ++i) {
      if (ids[static_cast<std::size_t>(i)] == 0)
        scores.row(i) << (obs(i, 0) > 0.0 ? 1.0 : 0.0), (obs(i, 0) > 0.0 ? 0.0 : 1.0);
      else
        scores.row(i) << 0.5, 0.5;
    }
    return ag::from_eigen(scores).to(x.dtype());
  };
  EvalConfig config;
  config.episodes = 5;
  config.dtype = ag::Dtype::Float64;
  const EvaluationResult result = evaluate_with_envs(make_toy_env, policy, standardizer, tasks, {}, config, &usage);
  // Task a's states pick different modules (x0 takes both signs), so its mean usage is mixed, yet its routing is
  // decisive: only the per-state numbers tell it from task b.
  EXPECT_GT(result.tasks[0].module_usage.minCoeff(), 0.1);
  EXPECT_NEAR(result.tasks[0].selector_entropy, 0.0, 1e-12);
  EXPECT_NEAR(result.tasks[0].selector_top_score, 1.0, 1e-12);
  EXPECT_NEAR(result.tasks[1].selector_entropy, std::log(2.0), 1e-12);
  EXPECT_NEAR(result.tasks[1].selector_top_score, 0.5, 1e-12);
}

TEST(Evaluator, ProgressIsReportedOncePerTask) {
  FnPolicy policy = rowwise_linear_policy({3, 2, 3});
  EvalConfig config;
  config.episodes = 2;
  config.threads = 2;
  std::vector<int> calls(3, 0);
  const EvalProgressFn progress = [&](std::size_t i, const TaskEvaluation& t) {
    ++calls.at(i);
    EXPECT_EQ(t.episodes, 2);
  };
  evaluate_with_envs(make_toy_env, policy, make_standardizer(3), {"toy/a", "toy/b", "toy/c"}, {}, config, nullptr,
                     progress);
  EXPECT_EQ(calls, std::vector<int>({1, 1, 1}));
}

// ----- (5) errors -----

TEST(Evaluator, ErrorsNameTheTaskAndWhatWasExpected) {
  const PolicyShape shape = shape_of("gravity/1.0", 2);
  const Standardizer standardizer = make_standardizer(shape.observation_size);
  EvalConfig config;
  config.episodes = 2;

  FnPolicy wide(shape, [](const ag::Tensor& x, const std::vector<std::int64_t>&) {
    return ag::zeros({x.size(0), 7}, x.dtype());
  });
  EXPECT_THAT(error_of([&] {
                evaluate(wide, standardizer, {"gravity/0.5", "gravity/1.0"}, {}, config);
              }),
              AllOf(HasSubstr("gravity/"), HasSubstr("[2, 7]"), HasSubstr("expected [2, 6]")));

  FnPolicy policy = rowwise_linear_policy(shape);
  EXPECT_THAT(error_of([&] {
                evaluate(policy, standardizer, {"gravity/0.5", "gravity/1.0"}, {5000.0}, config);
              }),
              AllOf(HasSubstr("1 expert returns for 2 tasks"), HasSubstr("one per task")));
  EXPECT_THAT(error_of([&] {
                evaluate(policy, standardizer, {"gravity/0.5", "gravity/9.9"}, {}, config);
              }),
              AllOf(HasSubstr("gravity/9.9"), HasSubstr("gravity/1.0")));  // names the valid tasks too
  EXPECT_THAT(error_of([&] {
                evaluate(policy, standardizer, {"gravity/0.5", "gravity/1.0"}, {-1.0, 5000.0}, config);
              }),
              AllOf(HasSubstr("gravity/0.5"), HasSubstr("positive")));
  EXPECT_THAT(error_of([&] {
                evaluate(policy, standardizer, {"gravity/0.5", "gravity/1.0", "gravity/1.5"}, {}, config);
              }),
              AllOf(HasSubstr("3 tasks"), HasSubstr("built for 2")));
  EXPECT_THAT(error_of([&] { evaluate(policy, make_standardizer(5), {"gravity/0.5"}, {}, config); }),
              AllOf(HasSubstr("standardizer has 5"), HasSubstr("17")));
  EXPECT_THAT(error_of([&] { evaluate(policy, standardizer, {"mt10/reach"}, {}, config); }),
              AllOf(HasSubstr("mt10/reach"), HasSubstr("observations of size 39"), HasSubstr("expects 17")));
  EXPECT_THAT(error_of([&] { evaluate(policy, standardizer, {}, {}, config); }), HasSubstr("no tasks"));
  EvalConfig none = config;
  none.episodes = 0;
  EXPECT_THAT(error_of([&] { evaluate(policy, standardizer, {"gravity/1.0"}, {}, none); }),
              HasSubstr("episodes must be >= 1"));
  EvalConfig negative = config;
  negative.max_envs_per_task = -1;
  EXPECT_THAT(error_of([&] { evaluate(policy, standardizer, {"gravity/1.0"}, {}, negative); }),
              HasSubstr("max_envs_per_task must be >= 0"));

  // An env error raised on a helper thread reaches the caller with the env's own message.
  FnPolicy nan_policy(shape, [](const ag::Tensor& x, const std::vector<std::int64_t>&) {
    return ag::full({x.size(0), 6}, std::nan(""), x.dtype());
  });
  EvalConfig two = config;
  two.threads = 2;
  two.episodes = 8;
  EXPECT_THAT(error_of([&] { evaluate(nan_policy, standardizer, {"gravity/1.0"}, {}, two); }),
              AllOf(HasSubstr("gravity/1.0"), HasSubstr("NaN")));

  const ModuleUsageFn bad_usage = [](const ag::Tensor& x, const std::vector<std::int64_t>&) {
    return ag::zeros({x.size(0) + 1, 4}, x.dtype());
  };
  EXPECT_THAT(
      error_of([&] { evaluate(policy, standardizer, {"gravity/1.5"}, {}, config, &bad_usage); }),
      AllOf(HasSubstr("gravity/1.5"), HasSubstr("module usage"), HasSubstr("[3, 4]"), HasSubstr("expected [2, M]")));
}

// ----- timing (run by hand: --gtest_also_run_disabled_tests --gtest_filter='EvaluatorTiming*') -----

// A 3x128 tanh MLP policy over a whole task set, 100 episodes per task, on 1 and 2 threads (or only on
// MAPS_EVAL_TIMING_THREADS threads, to time each under /usr/bin/time; MAPS_EVAL_TIMING_MAX_ENVS sets
// max_envs_per_task).
void time_task_set(const std::string& set) {
  const std::vector<std::string> tasks = envs::task_names(set);
  MlpPolicy policy(shape_of(tasks.front(), static_cast<std::int64_t>(tasks.size())), 128, 3, 1);
  const Standardizer standardizer = make_standardizer(policy.shape().observation_size);
  const int horizon = envs::make_env(tasks.front())->spec().horizon;
  std::vector<int> thread_counts{1, 2};
  if (const char* only = std::getenv("MAPS_EVAL_TIMING_THREADS")) thread_counts = {std::atoi(only)};
  for (int threads : thread_counts) {
    EvalConfig config;
    config.threads = threads;
    if (const char* max_envs = std::getenv("MAPS_EVAL_TIMING_MAX_ENVS")) config.max_envs_per_task = std::atoi(max_envs);
    const EvaluationResult r = evaluate(policy, standardizer, tasks, {}, config);
    const double busy = r.setup_seconds + r.env_seconds + r.policy_seconds;
    std::printf(
        "%s, threads=%d, max_envs_per_task=%d: %zu tasks x %d episodes x %d steps in %.2f s wall; per task summed: env "
        "creation "
        "%.2f s (%.0f%%), env steps %.2f s (%.0f%%), standardise+act %.2f s (%.0f%%)\n",
        set.c_str(), threads, config.max_envs_per_task, tasks.size(), config.episodes, horizon, r.seconds,
        r.setup_seconds, 100.0 * r.setup_seconds / busy, r.env_seconds, 100.0 * r.env_seconds / busy, r.policy_seconds,
        100.0 * r.policy_seconds / busy);
  }
}

TEST(EvaluatorTiming, DISABLED_GravitySetWithA3x128TanhMlp) { time_task_set("gravity"); }
TEST(EvaluatorTiming, DISABLED_Mt10WithA3x128TanhMlp) { time_task_set("mt10"); }

}  // namespace
}  // namespace maps::core
