// Transfer's pieces (issue 17): a policy started from another run's parameters, frozen parameters, learning-rate
// factors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "maps/policies/maps_policy.h"
#include "maps/policies/mt_mh_bc.h"
#include "maps/training/init_from_run.h"
#include "maps/training/trainer.h"
#include "nn/optim/adam.h"
#include "tests/maps/data/synthetic_demos.h"

namespace maps::core {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::shared_ptr<MAPSPolicy> maps_for(std::int64_t tasks, std::uint64_t seed) {
  ag::Generator gen(seed);
  MAPSConfig config;
  config.modules = 3;
  config.module_hidden = {16};
  config.selector_hidden = {8};
  return std::make_shared<MAPSPolicy>(PolicyShape{3, 2, tasks}, config, gen);
}

std::vector<double> values(const Policy& policy, const std::string& name) { return policy.parameter(name).to_vector(); }

ag::RowMatrixD matrix(const Policy& policy, const std::string& name) {
  return ag::to_eigen_double(policy.parameter(name));
}

TEST(InitializeFrom, CopiesEveryParameterAndMapsTheSelectorsTaskColumnsByName) {
  const auto source = maps_for(2, 1);  // trained on b and c
  const auto target = maps_for(3, 2);  // a (new), b, c
  initialize_from(*target, {"t/a", "t/b", "t/c"}, *source, {"t/b", "t/c"});
  for (const auto& p : source->named_parameters()) {
    if (p.name != "selector.layers.0.weight") {
      EXPECT_EQ(values(*target, p.name), values(*source, p.name)) << p.name;
    }
  }
  const ag::RowMatrixD from = matrix(*source, "selector.layers.0.weight"),
                       to = matrix(*target, "selector.layers.0.weight");
  ASSERT_EQ(to.cols(), 3 + 3);
  EXPECT_EQ(to.leftCols(3), from.leftCols(3));                               // the state's columns
  EXPECT_EQ(to.col(4), from.col(3));                                         // b
  EXPECT_EQ(to.col(5), from.col(4));                                         // c
  EXPECT_TRUE(to.col(3).isApprox(0.5 * (from.col(3) + from.col(4)), 1e-6));  // a: the mean of the known tasks
}

TEST(InitializeFrom, MapsTaskColumnsByNameWhenTheCountIsTheSame) {
  const auto source = maps_for(2, 1);  // trained on b and c
  const ag::RowMatrixD from = matrix(*source, "selector.layers.0.weight");
  const auto swapped = maps_for(2, 2);
  initialize_from(*swapped, {"t/c", "t/b"}, *source, {"t/b", "t/c"});
  const ag::RowMatrixD to = matrix(*swapped, "selector.layers.0.weight");
  EXPECT_EQ(to.leftCols(3), from.leftCols(3));
  EXPECT_EQ(to.col(3), from.col(4));  // c
  EXPECT_EQ(to.col(4), from.col(3));  // b
  const auto other = maps_for(2, 3);
  initialize_from(*other, {"t/a", "t/b"}, *source, {"t/b", "t/c"});
  const ag::RowMatrixD mixed = matrix(*other, "selector.layers.0.weight");
  EXPECT_TRUE(mixed.col(3).isApprox(0.5 * (from.col(3) + from.col(4)), 1e-6));  // a: new
  EXPECT_EQ(mixed.col(4), from.col(3));                                         // b
}

TEST(InitializeFrom, ParametersThatDifferOtherwiseAreNamed) {
  ag::Generator gen(3);
  const auto source = std::make_shared<MTMHBC>(PolicyShape{3, 2, 2}, gen, std::vector<std::int64_t>{8});
  const auto target = std::make_shared<MTMHBC>(PolicyShape{3, 2, 3}, gen, std::vector<std::int64_t>{8});
  EXPECT_THAT(
      [&] {
        initialize_from(*target, {"a", "b", "c"}, *source, {"b", "c"});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("is not a [state, task] input layer")));
  const auto maps = maps_for(2, 4);
  EXPECT_THAT(
      [&] {
        initialize_from(*maps, {"b", "c"}, *source, {"b", "c"});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("has no parameter")));
}

TrainConfig short_training() {
  TrainConfig c;
  c.steps = 30;
  c.states_per_task = 16;
  c.validate_every = 10;
  c.checkpoint_every = 10;
  c.learning_rate = 3e-3;
  return c;
}

TEST(TrainerFreeze, FrozenParametersStayBitForBitAndTheRestTrains) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const auto policy = maps_for(2, 5);
  const auto before = maps_for(2, 5);
  TrainConfig config = short_training();
  config.freeze = {"modules", "head"};
  const fs::path dir = fs::temp_directory_path() / "maps_transfer_test_freeze";
  fs::remove_all(dir);
  train_policy(*policy, data, config, dir.string(), nullptr);
  for (const auto& p : before->named_parameters()) {
    const bool frozen = p.name.rfind("modules", 0) == 0 || p.name.rfind("head", 0) == 0;
    if (frozen) {
      EXPECT_EQ(values(*policy, p.name), values(*before, p.name)) << p.name << " moved";
    } else {
      EXPECT_NE(values(*policy, p.name), values(*before, p.name)) << p.name << " did not train";
    }
  }
  config.freeze = {"modulez"};
  fs::remove_all(dir);
  EXPECT_THAT([&] { train_policy(*maps_for(2, 5), data, config, dir.string(), nullptr); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("'modulez' starts no parameter name")));
  config.freeze = {""};
  EXPECT_THAT([&] { train_policy(*maps_for(2, 5), data, config, dir.string(), nullptr); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("nothing to train")));
  fs::remove_all(dir);
}

TEST(TrainerFreeze, TransfersDefaultKeepsTheSourcesModulesAndTeachesTheNewTasksColumn) {
  // What `maps transfer` does by default: a one-task policy started from a run without that task, modules frozen.
  DataConfig only_a;
  only_a.tasks = {"synthetic/a"};
  const DemoDataset data(synthetic_demo_file(), only_a);
  const auto source = maps_for(1, 6);  // trained on b alone
  const auto policy = maps_for(1, 7);
  initialize_from(*policy, {"synthetic/a"}, *source, {"synthetic/b"});
  const ag::RowMatrixD column_before = matrix(*policy, "selector.layers.0.weight").col(3);
  TrainConfig config = short_training();
  config.freeze = {"modules"};
  const fs::path dir = fs::temp_directory_path() / "maps_transfer_test_default_freeze";
  fs::remove_all(dir);
  train_policy(*policy, data, config, dir.string(), nullptr);
  for (const auto& p : source->named_parameters()) {
    if (p.name.rfind("modules", 0) == 0) {
      EXPECT_EQ(values(*policy, p.name), values(*source, p.name)) << p.name << " moved";
    } else if (p.name != "selector.layers.0.weight") {
      EXPECT_NE(values(*policy, p.name), values(*source, p.name)) << p.name << " did not train";
    }
  }
  EXPECT_FALSE(matrix(*policy, "selector.layers.0.weight").col(3).isApprox(column_before))
      << "the new task's selector column did not train";
  fs::remove_all(dir);
}

TEST(AdamLrScale, ScalesOneParametersStepAndLeavesTheOthers) {
  ag::Tensor a = ag::from_vector(std::vector<double>{1.0, -2.0}, {2}, ag::Dtype::Float64).requires_grad_(true);
  ag::Tensor b = ag::from_vector(std::vector<double>{1.0, -2.0}, {2}, ag::Dtype::Float64).requires_grad_(true);
  optim::Adam adam({a, b}, {.lr = 0.1});
  adam.set_lr_scale(1, 0.25);
  ag::sum(ag::square(a) + ag::square(b)).backward();
  adam.step();
  // The first Adam step moves each entry by lr (times the factor) against its gradient's sign.
  EXPECT_NEAR(a.at(0), 1.0 - 0.1, 1e-7);
  EXPECT_NEAR(b.at(0), 1.0 - 0.025, 1e-7);
  EXPECT_NEAR(b.at(1), -2.0 + 0.025, 1e-7);
  EXPECT_THROW(adam.set_lr_scale(2, 1.0), std::out_of_range);
  EXPECT_THROW(adam.set_lr_scale(0, -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace maps::core
