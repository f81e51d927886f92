// The average of the parameters (weight_average.h; train.ema_power): its decay and updates by hand, the swap into
// the policy and back, its refusals, and in the trainer: best.ckpt keeps the average, last.ckpt holds it beside the
// trained parameters, a resumed run ends exactly where an uninterrupted one does, and a run resumes only with the
// setting it began with.

#include "maps/training/weight_average.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "autograd/autograd.h"
#include "maps/policies/mt_bc.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/run_config.h"
#include "maps/training/trainer.h"
#include "nn/serialize.h"
#include "tests/common/error_of.h"
#include "tests/common/scratch_path.h"
#include "tests/maps/data/synthetic_demos.h"

namespace maps::core {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(WeightAverage, DecayIsDiffusionPolicysPowerScheduleCapped) {
  EXPECT_EQ(WeightAverage::decay(1, 0.75, 0.9999), 0.0);
  EXPECT_EQ(WeightAverage::decay(2, 0.75, 0.9999), 0.0);
  EXPECT_DOUBLE_EQ(WeightAverage::decay(3, 0.75, 0.9999), 1.0 - std::pow(2.0, -0.75));
  EXPECT_DOUBLE_EQ(WeightAverage::decay(101, 0.75, 0.9999), 1.0 - std::pow(100.0, -0.75));
  EXPECT_EQ(WeightAverage::decay(100000000, 0.75, 0.9999), 0.9999);
  EXPECT_EQ(WeightAverage::decay(5, 0.75, 0.0), 0.0);  // max decay 0: the average is the parameters
}

TEST(WeightAverage, UpdatesByHandAndSwapsIntoTheParametersAndBack) {
  ag::Tensor w = ag::from_vector(std::vector<double>{1.0, -2.0}, {2}, ag::Dtype::Float64).requires_grad_();
  WeightAverage average({{"w", w}}, 1.0, 0.9);
  double expected[2] = {1.0, -2.0};
  for (std::int64_t update = 1; update <= 4; ++update) {
    ag::NoGradGuard no_grad;
    w.copy_(w + 1.0);  // an optimiser's step
    average.update(update);
    const double d = update <= 2 ? 0.0 : std::min(0.9, 1.0 - 1.0 / static_cast<double>(update - 1));  // power 1
    for (int i = 0; i < 2; ++i) expected[i] = d * expected[i] + (1.0 - d) * w.to_vector()[i];
  }
  const std::vector<double> averaged = average.values()[0].tensor.to_vector();
  EXPECT_DOUBLE_EQ(averaged[0], expected[0]);
  EXPECT_DOUBLE_EQ(averaged[1], expected[1]);
  EXPECT_NE(averaged, w.to_vector());
  const std::vector<double> trained = w.to_vector();
  {
    const WeightAverage::Applied applied(&average);
    EXPECT_EQ(w.to_vector(), averaged);
  }
  EXPECT_EQ(w.to_vector(), trained);
  average.apply();  // for good, as a finished run's last step is evaluated
  EXPECT_EQ(w.to_vector(), averaged);
  EXPECT_TRUE(w.requires_grad());
}

TEST(WeightAverage, ACheckpointsAverageIsHeldToTheSettingItIsReadWith) {
  TrainingState recorded;
  recorded.ema_power = 0.75;
  recorded.ema_max_decay = 0.9999;
  EXPECT_NO_THROW(check_average_agrees("c.ckpt", recorded, true, 0.75, 0.9999, "this run", AverageUse::kResume));
  EXPECT_NO_THROW(check_average_agrees("c.ckpt", TrainingState{}, false, 0.0, 0.9999, "this run", AverageUse::kResume));
  // Written before the power and cap were recorded: held only to holding an average.
  EXPECT_NO_THROW(
      check_average_agrees("c.ckpt", TrainingState{}, true, 0.5, 0.99, "run's config.json", AverageUse::kEvaluate));
  EXPECT_THAT(
      error_of([&] { check_average_agrees("c.ckpt", recorded, true, 0.0, 0.9999, "this run", AverageUse::kResume); }),
      HasSubstr("training checkpoint c.ckpt holds an average of the weights, and this run has "
                "train.ema_power 0.0: a run resumes with the train.ema_power it began with"));
  EXPECT_THAT(error_of([&] {
                check_average_agrees("c.ckpt", TrainingState{}, false, 0.75, 0.9999, "r's config.json",
                                     AverageUse::kEvaluate);
              }),
              HasSubstr("training checkpoint c.ckpt holds no average of the weights, and r's config.json has "
                        "train.ema_power 0.75"));
  const std::string evaluating = error_of(
      [&] { check_average_agrees("c.ckpt", recorded, true, 0.75, 0.999, "r's config.json", AverageUse::kEvaluate); });
  EXPECT_THAT(evaluating, HasSubstr("averages the weights with train.ema_power 0.75 and ema_max_decay 0.9999, and "
                                    "r's config.json has 0.75 and 0.999"));
  EXPECT_THAT(evaluating, Not(HasSubstr("resumes")));
}

TEST(WeightAverage, RefusesSettingsAndValuesThatDoNotFit) {
  ag::Tensor w = ag::zeros({2}, ag::Dtype::Float32);
  EXPECT_THAT(error_of([&] { WeightAverage({{"w", w}}, 0.0, 0.9); }), HasSubstr("train.ema_power"));
  EXPECT_THAT(error_of([&] { WeightAverage({{"w", w}}, 0.75, 1.0); }), HasSubstr("train.ema_max_decay"));
  WeightAverage average({{"w", w}}, 0.75, 0.9999);
  EXPECT_THAT(error_of([&] {
                average.load({{"w", ag::zeros({3}, ag::Dtype::Float32)}}, "ckpt");
              }),
              HasSubstr("ckpt: averaged parameter 0 is w [3]"));
  EXPECT_THAT(error_of([&] { average.load({}, "ckpt"); }), HasSubstr("holds 0 averaged parameters"));
}

TEST(WeightAverage, TheConfigKeysAreReadAndRefusedWhereTheyWouldDoNothing) {
  const auto config = [](const std::string& patch) {
    nlohmann::json j = nlohmann::json::parse(R"({"method": "diffusion_policy", "data": {"file": "x.h5"}})");
    j.merge_patch(nlohmann::json::parse(patch));
    return parse_run_config(j);
  };
  const RunConfig read = config(R"({"train": {"ema_power": 0.75, "ema_max_decay": 0.999}})");
  EXPECT_EQ(read.train.ema_power, 0.75);
  EXPECT_EQ(read.train.ema_max_decay, 0.999);
  EXPECT_EQ(config("{}").train.ema_power, 0.0);
  EXPECT_THAT(error_of([&] { config(R"({"train": {"ema_max_decay": 0.99}})"); }),
              HasSubstr("config train.ema_max_decay: set, but train.ema_power is 0 (no average)"));
  EXPECT_THAT(error_of([&] { config(R"({"train": {"ema_power": -1}})"); }), HasSubstr("train.ema_power"));
  EXPECT_THAT(error_of([&] { config(R"({"train": {"ema_power": 0.75, "ema_max_decay": 1}})"); }),
              HasSubstr("train.ema_max_decay"));
  EXPECT_THAT(error_of([&] {
                parse_run_config(nlohmann::json::parse(R"({"method": "maps", "imitation": "gail", "data": {"file":
                  "x.h5"}, "train": {"ema_power": 0.75}})"));
              }),
              HasSubstr("config train.ema_power: not available (PPO's policy keeps no average) under imitation"));
}

std::shared_ptr<Policy> averaging_mt_bc(std::uint64_t seed) {
  ag::Generator gen(seed);
  return std::make_shared<MTBC>(PolicyShape{3, 2, 2}, gen, std::vector<std::int64_t>{16});
}

TrainConfig averaging_config() {
  TrainConfig c;
  c.steps = 60;
  c.states_per_task = 16;
  c.validate_every = 60;  // one validation, at the end: best.ckpt is step 60's average
  c.checkpoint_every = 20;
  c.learning_rate = 1e-2;
  c.seed = 5;
  c.ema_power = 0.75;
  c.ema_max_decay = 0.9999;
  return c;
}

TEST(WeightAverage, TheTrainerKeepsTheAverageAndResumesItExactly) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const fs::path straight = scratch_path("maps_weight_average_straight");
  const fs::path resumed = scratch_path("maps_weight_average_resumed");
  train_policy(*averaging_mt_bc(1), data, averaging_config(), straight.string(), nullptr);
  const auto last = nn::load_tensors((straight / "last.ckpt").string());
  const auto best = nn::load_tensors((straight / "best.ckpt").string());
  const nn::NamedTensors averaged = nn::strip_prefix(last.tensors, "ema.");
  const nn::NamedTensors trained = nn::strip_prefix(last.tensors, "policy.");
  ASSERT_FALSE(averaged.empty());
  // best.ckpt holds the average, not the trained parameters.
  bool differs = false;
  for (const auto& average : averaged) {
    const std::string& name = average.name;  // not a structured binding: clang 14 cannot capture one
    const ag::Tensor& tensor = average.tensor;
    const auto kept =
        std::find_if(best.tensors.begin(), best.tensors.end(), [&](const auto& t) { return t.name == name; });
    ASSERT_NE(kept, best.tensors.end()) << name;
    EXPECT_EQ(kept->tensor.to_vector(), tensor.to_vector()) << name;
    const auto raw = std::find_if(trained.begin(), trained.end(), [&](const auto& t) { return t.name == name; });
    ASSERT_NE(raw, trained.end()) << name;
    differs = differs || raw->tensor.to_vector() != tensor.to_vector();
  }
  EXPECT_TRUE(differs);

  TrainConfig partial = averaging_config();
  partial.steps = 40;
  train_policy(*averaging_mt_bc(1), data, partial, resumed.string(), nullptr);
  train_policy(*averaging_mt_bc(99), data, averaging_config(), resumed.string(), nullptr);
  const auto again = nn::load_tensors((resumed / "last.ckpt").string());
  ASSERT_EQ(again.tensors.size(), last.tensors.size());
  for (std::size_t i = 0; i < last.tensors.size(); ++i)
    EXPECT_EQ(again.tensors[i].tensor.to_vector(), last.tensors[i].tensor.to_vector()) << last.tensors[i].name;

  // With keep_every, step_<N>.ckpt holds the average at step N too: the last kept step is the last step, whose
  // average last.ckpt holds.
  const fs::path kept = scratch_path("maps_weight_average_kept");
  TrainConfig keeping = averaging_config();
  keeping.keep_every = 30;
  train_policy(*averaging_mt_bc(1), data, keeping, kept.string(), nullptr);
  const auto step_60 = nn::load_tensors((kept / "step_60.ckpt").string());
  for (const auto& average : averaged) {
    const std::string& name = average.name;
    const auto at =
        std::find_if(step_60.tensors.begin(), step_60.tensors.end(), [&](const auto& t) { return t.name == name; });
    ASSERT_NE(at, step_60.tensors.end()) << name;
    EXPECT_EQ(at->tensor.to_vector(), average.tensor.to_vector()) << name;
  }

  // A run resumes only with the setting it began with.
  TrainConfig without = averaging_config();
  without.ema_power = 0.0;
  without.steps = 80;
  EXPECT_THAT(error_of([&] { train_policy(*averaging_mt_bc(1), data, without, straight.string(), nullptr); }),
              HasSubstr("a run resumes with the train.ema_power it began with"));
  // ... and with the same average: last.ckpt records its power and cap.
  EXPECT_EQ(read_training_state(last.config, "last.ckpt").ema_power, 0.75);
  EXPECT_EQ(read_training_state(last.config, "last.ckpt").ema_max_decay, 0.9999);
  TrainConfig other_power = averaging_config();
  other_power.ema_power = 0.5;
  other_power.steps = 80;
  EXPECT_THAT(error_of([&] { train_policy(*averaging_mt_bc(1), data, other_power, straight.string(), nullptr); }),
              HasSubstr("averages the weights with train.ema_power 0.75 and ema_max_decay 0.9999, and this run "
                        "has 0.5 and 0.9999: a run resumes with the average it began with"));
  TrainConfig other_cap = averaging_config();
  other_cap.ema_max_decay = 0.999;
  other_cap.steps = 80;
  EXPECT_THAT(error_of([&] { train_policy(*averaging_mt_bc(1), data, other_cap, straight.string(), nullptr); }),
              HasSubstr("and this run has 0.75 and 0.999"));
}

}  // namespace
}  // namespace maps::core
