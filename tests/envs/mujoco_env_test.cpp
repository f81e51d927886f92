#include "envs/mujoco_env.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

namespace maps::envs {
namespace {

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

}  // namespace
}  // namespace maps::envs
