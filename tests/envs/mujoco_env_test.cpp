#include "envs/mujoco_env.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

namespace maps::envs {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

TEST(MujocoLoad, CompilesModelFromString) {
  const auto model = load_model_from_string(
      "<mujoco><worldbody><body><joint type='slide'/><geom size='0.1'/></body></worldbody></mujoco>", "tiny");
  ASSERT_NE(model, nullptr);
  EXPECT_EQ(model->nq, 1);
}

TEST(MujocoLoad, BadXmlErrorNamesTaskAndCarriesMujocoMessage) {
  try {
    load_model_from_string("<mujoco><worldbody><geom type='nonsense'/></worldbody></mujoco>", "my/task");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("my/task"));
    EXPECT_THAT(e.what(), HasSubstr("nonsense"));
  }
}

TEST(MujocoLoad, MissingFileErrorNamesFile) {
  EXPECT_THAT([] { load_model_from_file("/nonexistent/model.xml"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("/nonexistent/model.xml")));
}

TEST(MujocoLoad, FindsHalfCheetahAssetAndLoadsIt) {
  const auto path = asset_path("half_cheetah.xml");
  EXPECT_TRUE(std::filesystem::is_regular_file(path));
  const auto model = load_model_from_file(path);
  EXPECT_EQ(model->nq, 9);
  EXPECT_EQ(model->nu, 6);
}

TEST(MujocoLoad, MissingAssetErrorNamesIt) {
  EXPECT_THAT([] { asset_path("no_such_model.xml"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("no_such_model.xml")));
}

// Three balls dropped onto a floor: three contacts once they land, one more than the model has room for when
// `nconmax` is 2.
class DropEnv : public MujocoEnv {
 public:
  explicit DropEnv(int nconmax)
      : MujocoEnv(unit_box_spec("toy/drop", 0, 1, 1, 200),
                  load_model_from_string("<mujoco><size nconmax='" + std::to_string(nconmax) +
                                             "' njmax='50'/><worldbody><geom type='plane' size='5 5 0.1'/>"
                                             "<body pos='0 0 0.3'><freejoint/><geom size='0.1'/></body>"
                                             "<body pos='1 0 0.3'><freejoint/><geom size='0.1'/></body>"
                                             "<body pos='2 0 0.3'><freejoint/><geom size='0.1'/></body>"
                                             "</worldbody></mujoco>",
                                         "toy/drop"),
                  1) {}

 protected:
  Eigen::VectorXd reset_model(std::mt19937_64&) override { return Eigen::VectorXd::Zero(1); }
  StepResult step_clipped(const Eigen::VectorXd&) override {
    mj_step(model(), mutable_data());
    StepResult r;
    r.observation = Eigen::VectorXd::Constant(1, data()->qpos[2]);
    return r;
  }
};

TEST(MujocoEnv, RunningOutOfContactRoomIsAnErrorNotSilentlyDroppedContacts) {
  DropEnv roomy(10), cramped(2);
  roomy.reset(0);
  cramped.reset(0);
  for (int t = 0; t < 199; ++t) roomy.step(Eigen::VectorXd::Zero(1));
  EXPECT_EQ(roomy.data()->ncon, 3);
  EXPECT_THAT(
      [&] {
        for (int t = 0; t < 199; ++t) cramped.step(Eigen::VectorXd::Zero(1));
      },
      ::testing::ThrowsMessage<std::runtime_error>(AllOf(HasSubstr("toy/drop"), HasSubstr("nconmax 2"))));
  // A reset starts clean: the steps before the balls land are fine again.
  cramped.reset(0);
  EXPECT_NO_THROW(cramped.step(Eigen::VectorXd::Zero(1)));
}

}  // namespace
}  // namespace maps::envs
