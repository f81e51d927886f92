#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "envs/demo_collection.h"
#include "envs/mt10/tasks.h"
#include "envs/seed_ranges.h"
#include "envs/task_expert.h"
#include "envs/task_sets.h"

namespace maps::envs::mt10 {
namespace {

using ::testing::HasSubstr;

std::unique_ptr<MT10Env> make(const std::string& task, MT10Options options = {}) {
  const MT10Task& entry = mt10_task(task);
  return entry.make(task, task_index(task), options);
}

Eigen::VectorXd wiggle(int t) {
  Eigen::VectorXd a(4);
  for (int j = 0; j < 4; ++j) a[j] = 1.3 * std::sin(0.31 * t + 1.7 * j);
  return a;
}

class MT10Task_ : public ::testing::TestWithParam<std::string> {};

TEST_P(MT10Task_, SpecAndObservationLayout) {
  const auto env = make(GetParam());
  EXPECT_EQ(env->spec().observation_size, 39);
  EXPECT_EQ(env->spec().action_size, 4);
  EXPECT_EQ(env->spec().horizon, 150);
  EXPECT_EQ(env->spec().task_index, task_index(GetParam()));
  const Eigen::VectorXd obs = env->reset(3);
  ASSERT_EQ(obs.size(), 39);
  EXPECT_TRUE(obs.allFinite());
  EXPECT_TRUE(obs.segment<3>(0).isApprox(env->hand_position()));
  EXPECT_NEAR(obs[3], 1.0, 0.02);                           // fingers open at reset
  EXPECT_EQ(obs.segment<7>(11), Eigen::VectorXd::Zero(7));  // no second object
  EXPECT_EQ(obs.segment<18>(18), obs.segment<18>(0));       // the first previous frame repeats the current one
  EXPECT_EQ(Eigen::Vector3d(obs.segment<3>(36)), env->goal());
  const StepResult r = env->step(wiggle(0));
  EXPECT_EQ(r.observation.segment<18>(18), obs.segment<18>(0));  // then it is the previous step's frame
}

TEST_P(MT10Task_, SameSeedSameTrajectoryOtherSeedOtherPlacement) {
  const auto a = make(GetParam());
  const auto b = make(GetParam());
  EXPECT_EQ(a->reset(11), b->reset(11));
  for (int t = 0; t < 40; ++t) ASSERT_EQ(a->step(wiggle(t)).observation, b->step(wiggle(t)).observation) << t;
  const Eigen::VectorXd first = a->reset(11);
  const Eigen::VectorXd other = a->reset(12);
  // The object or the goal moved (every task randomises one of them).
  EXPECT_GT((first.segment<3>(4) - other.segment<3>(4)).norm() + (first.segment<3>(36) - other.segment<3>(36)).norm(),
            1e-3);
}

TEST_P(MT10Task_, BadActionsAreErrorsNamingTheTaskAndOutOfRangeIsClipped) {
  const auto env = make(GetParam());
  env->reset(0);
  Eigen::VectorXd nan_action = Eigen::VectorXd::Zero(4);
  nan_action[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT([&] { env->step(nan_action); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(GetParam())));
  EXPECT_THAT([&] { env->step(Eigen::VectorXd::Zero(6)); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(GetParam())));
  const auto clipped = make(GetParam());
  env->reset(5);
  clipped->reset(5);
  for (int t = 0; t < 10; ++t) {
    const Eigen::VectorXd big = 7.0 * wiggle(t);
    ASSERT_EQ(env->step(big).observation, clipped->step(big.cwiseMax(-1.0).cwiseMin(1.0)).observation);
  }
}

TEST_P(MT10Task_, ExpertSucceedsAndDoingNothingDoesNot) {
  const auto env = make(GetParam());
  const TaskExpert expert = load_task_expert(GetParam());
  const double documented = mt10_task(GetParam()).documented_success;
  constexpr int kEpisodes = 20;
  int expert_successes = 0;
  for (int e = 0; e < kEpisodes; ++e) {
    Eigen::VectorXd obs = env->reset(kEvalSeedBegin + e);
    bool success = false;
    for (bool done = false; !done;) {
      const StepResult r = env->step(expert.mean_action(obs));
      success = success || r.success;
      obs = r.observation;
      done = r.done();
    }
    expert_successes += success ? 1 : 0;
  }
  // 20 episodes estimate the documented rate (over 100) to within about 0.1.
  EXPECT_GE(expert_successes / static_cast<double>(kEpisodes), documented - 0.1) << GetParam();
  for (int e = 0; e < 5; ++e) {
    env->reset(kEvalSeedBegin + e);
    for (bool done = false; !done;) {
      const StepResult r = env->step(Eigen::VectorXd::Zero(4));
      ASSERT_FALSE(r.success) << GetParam() << ": success with no action, episode " << e;
      done = r.done();
    }
  }
}

std::vector<std::string> all_mt10_tasks() { return task_names("mt10"); }

INSTANTIATE_TEST_SUITE_P(MT10, MT10Task_, ::testing::ValuesIn(all_mt10_tasks()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param.substr(5);
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

TEST(MT10Env, ActionMovesTheMocapTargetAndTheHandFollows) {
  const auto env = make("mt10/reach");
  const Eigen::VectorXd start = env->reset(0);
  Eigen::VectorXd obs = start;
  for (int t = 0; t < 30; ++t) obs = env->step(Eigen::Vector4d(1.0, 0.0, 0.0, 0.0)).observation;
  // 30 steps of +1 in x ask for 0.30 m at 0.8 m/s; the welded hand lags its moving target by a few centimetres,
  // then settles onto it.
  EXPECT_NEAR(obs[0] - start[0], 0.30, 0.04);
  for (int t = 0; t < 20; ++t) obs = env->step(Eigen::Vector4d::Zero()).observation;
  EXPECT_NEAR(obs[0] - start[0], 0.30, 0.003);
  EXPECT_NEAR(obs[1], start[1], 0.003);
  EXPECT_NEAR(obs[2], start[2], 0.003);
}

TEST(MT10Env, WorkspaceBoxClipsTheTarget) {
  const auto env = make("mt10/reach");
  env->reset(0);
  Eigen::VectorXd obs;
  for (int t = 0; t < 100; ++t) obs = env->step(Eigen::Vector4d(0.0, 0.0, -1.0, 0.0)).observation;
  EXPECT_NEAR(obs[2], 0.05, 0.005);  // the lowest target: fingertips 5 mm above the table
}

TEST(MT10Env, GripperClosesToItsRangeOnNothing) {
  const auto env = make("mt10/reach");
  env->reset(0);
  Eigen::VectorXd obs;
  for (int t = 0; t < 40; ++t) obs = env->step(Eigen::Vector4d(0.0, 0.0, 0.0, 1.0)).observation;
  EXPECT_NEAR(obs[3], 0.3, 0.02);  // fingertips 0.03 m apart
  for (int t = 0; t < 40; ++t) obs = env->step(Eigen::Vector4d(0.0, 0.0, 0.0, -1.0)).observation;
  EXPECT_NEAR(obs[3], 1.0, 0.02);
}

TEST(MT10Env, EndOnSuccessAndHorizonAreOptions) {
  MT10Options options;
  options.horizon = 500;
  options.end_on_success = true;
  const auto env = make("mt10/reach", options);
  EXPECT_EQ(env->spec().horizon, 500);
  const TaskExpert expert = load_task_expert("mt10/reach");
  Eigen::VectorXd obs = env->reset(1);
  StepResult r;
  int steps = 0;
  do {
    r = env->step(expert.mean_action(obs));
    obs = r.observation;
    ++steps;
  } while (!r.done());
  EXPECT_TRUE(r.success);
  EXPECT_TRUE(r.terminated);
  EXPECT_LT(steps, 150);
  MT10Options bad;
  bad.horizon = 0;
  EXPECT_THAT([&] { make("mt10/reach", bad); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("horizon")));
}

TEST(MT10Env, DemonstrationsSucceedAndReplayExactly) {
  const auto env = make("mt10/pick-place");
  DemoCollectionConfig config;
  config.demos = 2;
  config.require_success = true;
  config.min_return_fraction = 0.0;
  const TaskDemonstrations out = collect_task_demonstrations(*env, load_task_expert("mt10/pick-place"), config);
  ASSERT_EQ(out.demos.size(), 2u);
  for (const Demonstration& d : out.demos) {
    EXPECT_TRUE(d.success);
    ASSERT_EQ(d.num_samples(), 150);
    EXPECT_EQ(d.obs.cols(), 39);
    EXPECT_LE(d.actions.cwiseAbs().maxCoeff(), 1.0);
    Eigen::VectorXd obs = env->reset(d.seed);
    for (int t = 0; t < d.num_samples(); ++t) {
      ASSERT_EQ(obs, d.obs.row(t).transpose()) << t;
      const StepResult r = env->step(d.actions.row(t).transpose());
      ASSERT_EQ(r.reward, d.rewards[t]) << t;
      obs = r.observation;
    }
  }
}

// Each task file registers its own entry (envs/mt10/tasks.h): all ten are linked in and ordered as Meta-World orders
// them, which makes their one-hot indices, with the expert success rates docs/mt10.md reports.
TEST(MT10Tasks, TheTenTasksInMetaWorldsOrder) {
  const std::vector<std::pair<std::string, double>> expected = {
      {"reach", 1.0},       {"push", 1.0},         {"pick-place", 1.0},           {"door-open", 0.99},
      {"drawer-open", 1.0}, {"drawer-close", 1.0}, {"button-press-topdown", 1.0}, {"peg-insert-side", 1.0},
      {"window-open", 1.0}, {"window-close", 1.0}};
  const std::vector<MT10Task>& tasks = mt10_tasks();
  ASSERT_EQ(tasks.size(), expected.size());
  std::vector<std::string> set_names;
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const auto& [name, success] = expected[i];
    EXPECT_EQ(tasks[i].name, name) << i;
    EXPECT_EQ(tasks[i].index, static_cast<std::int64_t>(i)) << name;
    EXPECT_EQ(tasks[i].documented_success, success) << name;
    EXPECT_NE(tasks[i].make, nullptr) << name;
    EXPECT_NE(tasks[i].expert, nullptr) << name;
    EXPECT_EQ(&mt10_task("mt10/" + name), &tasks[i]);
    EXPECT_EQ(task_index("mt10/" + name), static_cast<std::int64_t>(i));
    set_names.push_back("mt10/" + name);
  }
  EXPECT_EQ(task_names("mt10"), set_names);
}

TEST(MT10Tasks, RegistrationsAreOrderedByIndexAndGapsRepeatsAndStrayIndicesRefused) {
  const auto entry = [](const std::string& name, std::int64_t index) { return MT10Task{.name = name, .index = index}; };
  const auto refused = [](const std::string& what) {
    return ::testing::ThrowsMessage<std::logic_error>(HasSubstr(what));
  };
  const MT10Task a = entry("a", 0), b = entry("b", 1), c1 = entry("c", 1), c2 = entry("c", 2), c3 = entry("c", 3);
  std::vector<std::string> names;
  for (const MT10Task& task : ordered_mt10_tasks({c2, a, b}, 3)) names.push_back(task.name);
  EXPECT_EQ(names, (std::vector<std::string>{"a", "b", "c"}));
  EXPECT_THAT([&] { ordered_mt10_tasks({a, c2}, 3); }, refused("no task has index 1"));
  EXPECT_THAT([&] { ordered_mt10_tasks({a, b}, 3); }, refused("no task has index 2"));
  EXPECT_THAT([&] { ordered_mt10_tasks({}, 3); }, refused("no task has index 0"));
  EXPECT_THAT([&] { ordered_mt10_tasks({}, 3); }, refused("registered: none"));
  EXPECT_THAT([&] { ordered_mt10_tasks({b, a, c1}, 3); }, refused("tasks 'b' and 'c' both have index 1"));
  EXPECT_THAT([&] { ordered_mt10_tasks({a, b, c3}, 3); }, refused("task 'c' has index 3, outside 0 to 2"));
  EXPECT_THAT([&] { ordered_mt10_tasks({entry("z", -1), a, b}, 3); }, refused("task 'z' has index -1"));
  EXPECT_THAT([&] { ordered_mt10_tasks({a, entry("a", 1)}, 2); }, refused("task 'a' is registered twice"));
}

TEST(MT10Env, UnknownTaskListsTheValidOnes) {
  EXPECT_THAT([] { mt10_task("mt10/open-box"); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("mt10/window-close")));
}

}  // namespace
}  // namespace maps::envs::mt10
