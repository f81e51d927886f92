#ifdef MAPS_HAVE_GIF
#include "envs/render/gif_file.h"

#include <gif_lib.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "envs/mujoco_env.h"
#include "envs/task_sets.h"

namespace maps::envs {
namespace {

using ::testing::HasSubstr;

// Frames of a real scene: the HalfCheetah a few steps apart (many colours, so quantisation is exercised).
std::vector<Image> cheetah_frames(int count) {
  auto env = make_env("gravity/1.0");
  auto& mujoco = dynamic_cast<MujocoEnv&>(*env);
  env->reset(0);
  OffscreenRenderer renderer(mujoco.model(), 80, 60);
  std::vector<Image> frames;
  for (int i = 0; i < count; ++i) {
    frames.push_back(renderer.render(mujoco.data(), CameraView{}));
    for (int s = 0; s < 5; ++s) env->step(Eigen::VectorXd::Constant(6, i % 2 ? 0.8 : -0.8));
  }
  return frames;
}

TEST(GifFile, AnimationRoundTripsThroughGiflib) {
  const std::vector<Image> frames = cheetah_frames(4);
  const auto path = std::filesystem::temp_directory_path() / "maps_gif_test.gif";
  write_gif(path.string(), frames, 7);
  EXPECT_NE(std::filesystem::status(path).permissions() & std::filesystem::perms::others_read,
            std::filesystem::perms::none);
  int error = 0;
  GifFileType* gif = DGifOpenFileName(path.string().c_str(), &error);
  ASSERT_NE(gif, nullptr) << GifErrorString(error);
  ASSERT_EQ(DGifSlurp(gif), GIF_OK) << GifErrorString(gif->Error);
  ASSERT_EQ(gif->ImageCount, 4);
  EXPECT_EQ(gif->SWidth, 80);
  EXPECT_EQ(gif->SHeight, 60);
  double worst_mean_error = 0.0;
  for (int f = 0; f < gif->ImageCount; ++f) {
    const SavedImage& image = gif->SavedImages[f];
    GraphicsControlBlock control{};
    ASSERT_EQ(DGifSavedExtensionToGCB(gif, f, &control), GIF_OK);
    EXPECT_EQ(control.DelayTime, 7);
    ASSERT_NE(image.ImageDesc.ColorMap, nullptr);
    // Each pixel's palette colour is close to the frame's: 256 colours per frame lose little of a render.
    double error_sum = 0.0;
    for (int i = 0; i < 80 * 60; ++i) {
      const GifColorType colour = image.ImageDesc.ColorMap->Colors[image.RasterBits[i]];
      const std::uint8_t* rgb = frames[f].rgb.data() + 3 * i;
      error_sum += std::abs(colour.Red - rgb[0]) + std::abs(colour.Green - rgb[1]) + std::abs(colour.Blue - rgb[2]);
    }
    worst_mean_error = std::max(worst_mean_error, error_sum / (80 * 60 * 3));
  }
  EXPECT_LT(worst_mean_error, 4.0);
  DGifCloseFile(gif, &error);
  std::filesystem::remove(path);
}

TEST(GifFile, BadFramesAndPathsAreNamed) {
  std::vector<Image> frames = cheetah_frames(2);
  const std::string dir = std::filesystem::temp_directory_path().string();
  EXPECT_THAT([&] { write_gif(dir + "/none.gif", {}, 5); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("no frames")));
  EXPECT_THAT([&] { write_gif(dir + "/delay.gif", frames, 0); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("delay")));
  frames[1].width = 40;
  EXPECT_THAT([&] { write_gif(dir + "/sizes.gif", frames, 5); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("differ in size")));
  frames.pop_back();
  EXPECT_THAT([&] { write_gif("/nonexistent-folder/x.gif", frames, 5); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("/nonexistent-folder/x.gif")));
  EXPECT_FALSE(std::filesystem::exists(dir + "/sizes.gif"));
}

}  // namespace
}  // namespace maps::envs
#endif
