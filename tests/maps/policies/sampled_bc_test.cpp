// The paper's code's BC loss (train.bc_loss "sampled", Policy::use_sampled_bc_loss) and MAML's "adapted"
// checkpoint rule (maml.validate).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "autograd/gradcheck.h"
#include "maps/policies/maml.h"
#include "maps/policies/maps_policy.h"
#include "maps/policies/mt_bc.h"
#include "maps/training/run_config.h"
#include "maps/training/trainer.h"
#include "tests/common/error_of.h"
#include "tests/common/scratch_path.h"
#include "tests/maps/data/synthetic_demos.h"
#include "tests/maps/policies/baseline_test_util.h"

namespace maps::core {
namespace {

using ag::Dtype;
using ag::Tensor;
using ::testing::HasSubstr;

std::shared_ptr<Policy> tiny_mt_bc(std::uint64_t seed, bool sampled) {
  ag::Generator gen(seed);
  auto policy = std::make_shared<MTBC>(PolicyShape{3, 2, 4}, gen, std::vector<std::int64_t>{8});
  if (sampled) policy->use_sampled_bc_loss();
  return policy;
}

TEST(SampledBCLoss, AddsALogStdParameterStartingAtZeroAndOnlyWhenAskedFor) {
  const auto plain = tiny_mt_bc(1, false);
  const auto sampled = tiny_mt_bc(1, true);
  EXPECT_FALSE(plain->sampled_bc_loss());
  EXPECT_EQ(plain->state_dict().size() + 1, sampled->state_dict().size());
  bool found = false;
  for (const auto& [name, tensor] : sampled->named_parameters())
    if (name == "log_std") {
      found = true;
      EXPECT_EQ(tensor.shape(), (ag::Shape{2}));
      EXPECT_EQ(tensor.to_vector(), (std::vector<double>{0.0, 0.0}));
      EXPECT_TRUE(tensor.requires_grad());
    }
  EXPECT_TRUE(found);
  // The mean action is the same function: the noise is a training matter only.
  const core::Batch batch = baselinetest::make_batch(4, 5, 7);
  EXPECT_EQ(plain->act(batch.observations, batch.tasks).to_vector(),
            sampled->act(batch.observations, batch.tasks).to_vector());
}

TEST(SampledBCLoss, IsAFunctionOfTheNoiseSeedAndAveragesToTheMeansErrorPlusTheVariance) {
  auto policy = tiny_mt_bc(2, true);
  policy->to(Dtype::Float64);
  core::Batch batch = baselinetest::make_batch(4, 8, 3, Dtype::Float64);
  const double mean_error = ag::mse_loss(policy->act(batch.observations, batch.tasks), batch.actions).item();
  batch.noise_seed = 11;
  const double first = policy->loss(batch).total.item();
  EXPECT_EQ(first, policy->loss(batch).total.item());
  batch.noise_seed = 12;
  EXPECT_NE(first, policy->loss(batch).total.item());
  // E[(a - mu - sigma eps)^2] = (a - mu)^2 + sigma^2, sigma = exp(0) = 1; 4000 draws of 64 rows x 2 dims: the
  // average's standard error is about 0.005.
  double sum = 0.0;
  const int draws = 4000;
  for (int d = 0; d < draws; ++d) {
    batch.noise_seed = 1000 + static_cast<std::uint64_t>(d);
    sum += policy->loss(batch).total.item();
  }
  EXPECT_NEAR(sum / draws, mean_error + 1.0, 0.03);
}

TEST(SampledBCLoss, GradcheckInTheLogStdAndTheObservationsForMTBCAndMAPS) {
  for (const bool maps_policy : {false, true}) {
    std::shared_ptr<Policy> policy;
    if (maps_policy) {
      ag::Generator gen(4);
      MAPSConfig config;
      config.module_hidden = {8};
      config.selector_hidden = {8};
      policy = std::make_shared<MAPSPolicy>(PolicyShape{3, 2, 4}, config, gen);
      policy->use_sampled_bc_loss();
    } else {
      policy = tiny_mt_bc(4, true);
    }
    policy->to(Dtype::Float64);
    core::Batch batch = baselinetest::make_batch(4, 3, 5, Dtype::Float64);
    batch.previous_observations = batch.observations;
    batch.per_task = 3;
    batch.noise_seed = 21;
    ag::Generator gen(6);
    const Tensor log_std = ag::rand({2}, gen, Dtype::Float64, -1.0, 0.5).requires_grad_();
    const Tensor obs = batch.observations.detach().requires_grad_();
    const auto f = [&](const std::vector<Tensor>& in) {
      policy->replace_parameter("log_std", in[0]);
      core::Batch b = batch;
      b.observations = in[1];
      return policy->loss(b).total;
    };
    const auto check =
        ag::gradcheck(maps_policy ? "MAPS sampled BC" : "MT-BC sampled BC", ag::SingleFunction(f), {log_std, obs});
    EXPECT_TRUE(check.ok) << check.message;
  }
}

TEST(SampledBCLoss, TrainingLowersTheLogStdAndAResumedRunDrawsTheSameNoise) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const PolicyShape shape{data.observation_size(), data.action_size(), data.num_tasks()};
  auto make = [&](std::uint64_t seed) {
    ag::Generator gen(seed);
    auto policy = std::make_shared<MTBC>(shape, gen, std::vector<std::int64_t>{16});
    policy->use_sampled_bc_loss();
    return policy;
  };
  TrainConfig config;
  config.steps = 60;
  config.states_per_task = 16;
  config.validate_every = 20;
  config.checkpoint_every = 20;
  config.learning_rate = 1e-2;
  config.seed = 3;
  const auto dir = [](const std::string& name) { return scratch_path("maps_sampled_bc_test_" + name).string(); };
  auto straight = make(1);
  train_policy(*straight, data, config, dir("straight"), nullptr);
  const auto last_log_std = [](const Policy& p) {
    for (const auto& [name, tensor] : p.named_parameters())
      if (name == "log_std") return tensor.to_vector();
    return std::vector<double>{};
  };
  // train_policy leaves the best checkpoint's policy; with lr 1e-2 for 20+ steps log_std has fallen well below 0.
  for (double v : last_log_std(*straight)) EXPECT_LT(v, -0.1);

  auto first = make(1);
  TrainConfig partial = config;
  partial.steps = 30;
  const std::string resumed_dir = dir("resumed");
  train_policy(*first, data, partial, resumed_dir, nullptr);
  auto second = make(77);
  train_policy(*second, data, config, resumed_dir, nullptr);
  const auto a = straight->state_dict(), b = second->state_dict();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].tensor.to_vector(), b[i].tensor.to_vector()) << a[i].name;
}

TEST(SampledBCLoss, TheRunConfigChoosesItAndRefusesItForMAMLAndUnknownNames) {
  auto request =
      nlohmann::json::parse(R"({"method": "mt_bc", "data": {"file": "x.h5"}, "train": {"bc_loss": "sampled"}})");
  const RunConfig config = parse_run_config(request);
  EXPECT_EQ(config.train.bc_loss, "sampled");
  EXPECT_TRUE(make_policy(config, {3, 2, 2})->sampled_bc_loss());
  EXPECT_EQ(to_json(config)["train"]["bc_loss"], "sampled");
  request["train"]["bc_loss"] = "gaussian";
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("train.bc_loss: expected \"mean\" or \"sampled\", got \"gaussian\""));
  request["train"]["bc_loss"] = "sampled";
  request["method"] = "maml";
  EXPECT_THAT(error_of([&] { parse_run_config(request); }), HasSubstr("not available for maml"));
}

TEST(MAMLValidate, AdaptedJudgesTheFineTunedPolicyAndLeavesThetaUnadapted) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const PolicyShape shape{data.observation_size(), data.action_size(), data.num_tasks()};
  MAMLConfig config;
  config.finetune_steps = 5;
  config.inner_lr = 0.05;
  config.validate = "adapted";
  ag::Generator gen(3);
  MAML maml(shape, gen, config, {16});
  maml.batch_per_task(8);
  const Batch validation = data.validation_batch(Dtype::Float32);
  const double unadapted = mean_action_error(maml, validation);
  const double adapted = maml.validation_loss(validation, data);
  EXPECT_FALSE(maml.adapted());
  EXPECT_EQ(mean_action_error(maml, validation), unadapted);
  // The same number as evaluating after prepare_for_evaluation, which keeps each task's best step count (0 included),
  // so it is never worse per task on the validation demos.
  maml.prepare_for_evaluation(data);
  EXPECT_EQ(mean_action_error(maml, validation), adapted);
  EXPECT_LE(adapted, unadapted + 1e-6);

  auto request =
      nlohmann::json::parse(R"({"method": "maml", "data": {"file": "x.h5"}, "maml": {"validate": "after"}})");
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("maml.validate: expected \"unadapted\" or \"adapted\", got \"after\""));
}

}  // namespace
}  // namespace maps::core
